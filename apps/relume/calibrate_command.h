// `relume calibrate response FILES... --exposures ...`: recovers the camera response from a
// bracket and writes it as a calibration profile (JSON) plus a plot of the curves.
// `relume calibrate chart IMAGE [--corners x,y,...]`: finds the ColorChecker, fits the neutral
// gain and colour matrix, writes the profile and a report (chart with patches outlined,
// swatches, Delta E 2000 per patch in JSON).
// The work is in calibration/; this file parses, loads files and writes results.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace relume::app {

// Exposure times from --exposures (seconds) or --ev (relative stops), one per file.
struct ExposureArgs {
  std::vector<double> exposures_s;
  std::vector<double> ev;
};

// `--session DIR --frames SELECTOR`: the frames come from a recorded session (their exposures
// from its records), and the result is also stored in the session's calibrations table with
// the ids of the frames it came from, so that processing applies it when it reads that
// device's frames.
struct SessionSource {
  std::string session;
  std::string frames;
  // Further sessions of the same camera to store the result in (a chart shot recorded as its
  // own short session before the day's capture). Stored there without source frame ids.
  std::vector<std::string> store_in;
};

struct CalibrateResponseArgs {
  std::vector<std::string> files;
  SessionSource source;
  ExposureArgs exposure;
  std::string method = "debevec";
  int samples = 300;
  double lambda = 60.0;
  std::string smoothness = "log-code";  // Debevec's smoothness term: code or log-code
  std::string out = "response.json";    // a calibration profile holding the response
  std::string plot;                     // PNG; default: <out without .json>.png
};
// Writes the profile and the plot; prints the summary. Throws relume::Error on bad input.
void RunCalibrateResponse(const CalibrateResponseArgs& args, std::ostream& out);

struct CalibrateChartArgs {
  std::string image;              // 8/16-bit camera image, or .exr radiance
  SessionSource source;           // instead of image: a session bracket, linearised and merged
  std::vector<double> corners;    // 8 numbers x0,y0,...,x3,y3 (any order around the chart)
  std::string corners_file;       // YAML: corners: [[x, y], [x, y], [x, y], [x, y]]
  std::string detector = "auto";  // auto, mcc, lattice
  std::string profile;            // an existing profile whose response linearises the image
  double exposure_s = 1.0;        // exposure of IMAGE when a response is applied
  std::string reference = "config/colorchecker/xrite_classic_2014_lab_d50.yaml";
  bool white_preserving = true;
  std::string out = "profile.json";
  std::string report_dir;  // default: <out without .json>_report
};
void RunCalibrateChart(const CalibrateChartArgs& args, std::ostream& out);

// Adds `calibrate` with its `response` and `chart` subcommands.
void AddCalibrateCommand(CLI::App& app);

// Shared with `relume hdr`: exposure times for `count` files (throws InvalidArgumentError
// naming the flag when the count differs or both/neither are given and none are known).
std::vector<double> ResolveExposures(const ExposureArgs& args, std::size_t count,
                                     const std::vector<double>& from_metadata = {});

}  // namespace relume::app
