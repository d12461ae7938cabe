#include "apps/relume/hdr_command.h"

#include <CLI/CLI.hpp>
#include <bit>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calibration/bracket.h"
#include "calibration/calibration_profile.h"
#include "calibration/hdr_merge.h"
#include "calibration/image_file.h"
#include "capture/path_policy.h"
#include "core/error.h"

namespace relume::app {

using namespace relume::calibration;

void RunHdrMerge(const HdrMergeArgs& args, std::ostream& out) {
  if (args.files.empty()) throw InvalidArgumentError("hdr merge: give the bracket's image files");
  {
    // Every file the merge writes is checked against every input before anything is read.
    std::filesystem::path base(args.out);
    base.replace_extension();
    std::vector<std::filesystem::path> inputs(args.files.begin(), args.files.end());
    if (!args.profile.empty()) inputs.emplace_back(args.profile);
    for (const std::string& output :
         {args.out, base.string() + "_contributors.png", base.string() + "_contributor_bits.png",
          base.string() + "_status.png", base.string() + "_report.json"}) {
      capture::CheckOutputFile(output, inputs, "--out");
    }
  }
  CheckRadianceFileName(args.out);  // before the work, not after it
  const ExrCompression compression = ParseExrCompression(args.exr_compression);
  std::vector<CameraImage> frames;
  std::vector<double> metadata_times;
  for (const auto& f : args.files) {
    LoadedFrame loaded = LoadFrame(f);
    frames.push_back(std::move(loaded.image));
    metadata_times.push_back(loaded.exposure_time_s);
  }
  const std::vector<double> times = ResolveExposures(args.exposure, frames.size(), metadata_times);
  for (std::size_t i = 0; i < times.size(); ++i) CheckExposureTime(times[i], "hdr merge: " + args.files[i]);
  std::optional<CalibrationProfile> profile;
  if (!args.profile.empty()) profile = LoadProfile(args.profile);
  CameraResponse response;
  if (frames.front().encoding == SampleEncoding::kSensorLinear) {
    response = SensorLinearResponse(frames.front());
  } else if (profile && profile->response) {
    response = *profile->response;
  } else {
    throw InvalidArgumentError(
        "hdr merge: camera-encoded images need a response; give --profile with one (relume calibrate response)");
  }
  HdrMergeOptions options;
  options.threads = args.threads;
  const auto start = std::chrono::steady_clock::now();
  HdrMergeResult merged = MergeHdr(frames, times, response, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RadianceImage radiance = merged.radiance;
  const bool corrected = profile && profile->gain_input == "radiance" && radiance.pixels.channels() == 3 &&
                         (!profile->gain.IsIdentity() || !profile->ccm.isIdentity());
  if (corrected) radiance = ApplyProfile(*profile, radiance);
  SaveRadianceExr(radiance, args.out, compression);
  std::filesystem::path base(args.out);
  base.replace_extension();
  // Number of contributing frames per pixel, scaled for viewing (255 = every frame).
  cv::Mat count(merged.contributors.size(), CV_8UC1);
  for (int y = 0; y < count.rows; ++y) {
    for (int x = 0; x < count.cols; ++x) {
      const int n = std::popcount(static_cast<unsigned>(merged.contributors.at<std::uint16_t>(y, x)));
      count.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(255 * n / static_cast<int>(frames.size()));
    }
  }
  SaveImage(count, base.string() + "_contributors.png");
  SaveImage(merged.contributors, base.string() + "_contributor_bits.png");
  cv::Mat status_view = merged.status * 100;
  SaveImage(status_view, base.string() + "_status.png");
  const HdrMergeSummary& s = merged.summary;
  nlohmann::json j = {{"files", args.files},
                      {"exposure_times_s", times},
                      {"frames", s.frames},
                      {"pixels", s.pixels},
                      {"pixels_saturated_everywhere", s.pixels_saturated_everywhere},
                      {"pixels_black_everywhere", s.pixels_black_everywhere},
                      {"threads", s.threads_used},
                      {"merge_seconds", seconds},
                      {"colour_corrected", corrected},
                      {"reason", s.reason}};
  std::ofstream(base.string() + "_report.json") << j.dump(1) << "\n";
  out << "hdr: " << s.BriefReport() << " in " << seconds << " s" << (corrected ? ", colour corrected" : "") << "\n";
  out << "wrote " << args.out << " and " << base.string() << "_{contributors.png, contributor_bits.png, status.png, "
      << "report.json}\n";
}

void AddHdrCommand(CLI::App& app) {
  CLI::App* hdr = app.add_subcommand("hdr", "High dynamic range radiance from exposure brackets");
  hdr->require_subcommand(1);
  auto a = std::make_shared<HdrMergeArgs>();
  CLI::App* merge = hdr->add_subcommand("merge", "Merge a bracket into a linear radiance EXR");
  merge->add_option("files", a->files, "Bracket images (8/16-bit with --profile, or raw files)")->required();
  merge->add_option("--exposures", a->exposure.exposures_s, "Exposure times in seconds, one per file")->delimiter(',');
  merge->add_option("--ev", a->exposure.ev, "EV values, one per file (relative exposures 2^EV)")->delimiter(',');
  merge->add_option("--profile", a->profile, "Calibration profile (response; gain and CCM applied when present)");
  merge->add_option("--out", a->out, "Output EXR")->capture_default_str();
  merge->add_option("--threads", a->threads, "Threads (0 = all cores)")->capture_default_str();
  merge
      ->add_option("--exr-compression", a->exr_compression,
                   "none, zip or piz (lossless; zip saves ~9 % on a photograph's noisy floats at 20x the write time)")
      ->capture_default_str();
  merge->callback([a]() { RunHdrMerge(*a, std::cout); });
}

}  // namespace relume::app
