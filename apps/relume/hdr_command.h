// `relume hdr merge FILES... --exposures ... --out FILE.exr`: merges a bracket into linear
// radiance (calibration/hdr_merge.h) with the response of a calibration profile (8-bit files)
// or the sensor's linearity (raw files), applies the profile's gain and colour matrix when it
// has them, and writes the EXR plus a report: contributing-frame count image (PNG), status
// image and a JSON summary.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "apps/relume/calibrate_command.h"

namespace CLI {
class App;
}

namespace relume::app {

struct HdrMergeArgs {
  std::vector<std::string> files;
  ExposureArgs exposure;
  std::string profile;  // required for 8/16-bit camera-encoded files
  std::string out = "merged.exr";
  int threads = 0;
  std::string exr_compression = "none";  // calibration::ParseExrCompression
};
void RunHdrMerge(const HdrMergeArgs& args, std::ostream& out);

void AddHdrCommand(CLI::App& app);

}  // namespace relume::app
