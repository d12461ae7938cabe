#include "apps/relume/calibrate_command.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/core.hpp>

#include "calibration/calibration_profile.h"
#include "calibration/camera_pose.h"
#include "calibration/colorchecker_detect.h"
#include "calibration/colorchecker_fit.h"
#include "calibration/image_file.h"
#include "calibration/intrinsics.h"
#include "calibration/markers.h"
#include "calibration/report_plots.h"
#include "calibration/response.h"
#include "calibration/rgbd_extrinsics.h"
#include "capture/path_policy.h"
#include "capture/rgbd_geometry.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/yaml_file.h"
#include "pipeline/radiance.h"

namespace relume::app {
namespace {

using namespace relume::calibration;

std::string WithoutJson(const std::string& path) {
  std::filesystem::path p(path);
  if (p.extension() == ".json") p.replace_extension();
  return p.string();
}

std::vector<cv::Point2f> CornersFromYaml(const std::string& path) {
  const YamlFile file(path);
  const YAML::Node corners = file.root()["corners"];
  if (!corners || !corners.IsSequence() || corners.size() != 4) {
    file.Fail(corners ? corners : file.root(), "corners", "expected a list of 4 [x, y] pairs");
  }
  std::vector<cv::Point2f> points;
  for (const auto& c : corners) {
    if (!c.IsSequence() || c.size() != 2) file.Fail(c, "corners", "each corner must be [x, y]");
    try {
      points.emplace_back(c[0].as<float>(), c[1].as<float>());
    } catch (const YAML::Exception&) {
      file.Fail(c, "corners", "corner coordinates must be numbers");
    }
  }
  return points;
}

// The frames a --session/--frames pair names: one device's still frames.
std::vector<capture::FrameRecord> SessionFrames(const capture::SessionReader& reader, const SessionSource& source) {
  if (source.frames.empty()) throw InvalidArgumentError("--session needs --frames (e.g. --frames bracket:1)");
  std::vector<capture::FrameRecord> frames;
  for (const capture::FrameRecord& f : pipeline::SelectFrames(reader, source.frames)) {
    if (f.stream == "still") frames.push_back(f);
  }
  if (frames.empty()) throw InvalidArgumentError("--frames " + source.frames + ": no still-camera frames selected");
  for (const capture::FrameRecord& f : frames) {
    if (f.device_id != frames.front().device_id) {
      throw InvalidArgumentError("--frames " + source.frames + " selects frames of " + frames.front().device_id +
                                 " and " + f.device_id + "; a calibration is of one camera");
    }
  }
  return frames;
}

// Stores a profile in the session with the frames it came from (empty when they are frames of
// another session); returns its id.
std::int64_t StoreInSession(const std::string& session, const std::string& kind, const CalibrationProfile& profile,
                            const std::vector<capture::FrameRecord>& frames, bool own_frames = true) {
  capture::CalibrationRecord record;
  record.created_utc =
      UtcTime(std::chrono::duration_cast<Nanoseconds>(std::chrono::system_clock::now().time_since_epoch()));
  record.kind = kind;
  record.device_id = frames.front().device_id;
  record.json = ProfileToJson(profile);
  if (own_frames) {
    for (const capture::FrameRecord& f : frames) record.source_frame_ids.push_back(f.id);
  }
  return capture::SessionWriter::Append(session)->AddCalibration(record);
}

// The --store-in sessions, each checked before anything is stored anywhere: a session holding
// the calibrated device, not the source session again. A bad one stores nothing at all, so a
// corrected retry does not duplicate rows.
std::vector<std::string> CheckStoreIn(const SessionSource& source, const std::string& device_id) {
  std::vector<std::string> targets;
  for (const std::string& other : source.store_in) {
    std::error_code ec;
    if (std::filesystem::equivalent(other, source.session, ec)) continue;  // stored there anyway
    const capture::SessionReader reader(other);                            // IoError naming it when it is not a session
    const auto devices = reader.Devices();
    if (std::none_of(devices.begin(), devices.end(),
                     [&](const drivers::DeviceInfo& d) { return d.FullId() == device_id; })) {
      throw InvalidArgumentError("--store-in " + other + ": that session has no device " + device_id +
                                 "; nothing was stored");
    }
    targets.push_back(other);
  }
  return targets;
}

// Stores the calibration in the source session and every --store-in session, and says so.
void StoreEverywhere(const SessionSource& source, const std::string& kind, const CalibrationProfile& profile,
                     const std::vector<capture::FrameRecord>& frames, std::ostream& out) {
  const std::vector<std::string> others = CheckStoreIn(source, frames.front().device_id);
  const std::int64_t id = StoreInSession(source.session, kind, profile, frames);
  out << "stored in " << source.session << " as calibration " << id << " (" << kind << " of " << profile.camera
      << ", from " << frames.size() << " frames; applied when its frames are processed)\n";
  for (const std::string& other : others) {
    const std::int64_t other_id = StoreInSession(other, kind, profile, frames, /*own_frames=*/false);
    out << "stored in " << other << " as calibration " << other_id << "\n";
  }
}

// Refuses outputs that would overwrite an input or land in a session's recorded data, before
// any work (capture/path_policy.h).
void CheckOutputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                  const std::vector<std::string>& inputs) {
  std::vector<std::filesystem::path> input_paths;
  for (const std::string& input : inputs) {
    if (!input.empty()) input_paths.emplace_back(input);
  }
  for (const auto& [flag, output] : outputs) capture::CheckOutputFile(output, input_paths, flag);
}

}  // namespace

std::vector<double> ResolveExposures(const ExposureArgs& args, std::size_t count,
                                     const std::vector<double>& from_metadata) {
  if (!args.exposures_s.empty() && !args.ev.empty()) {
    throw InvalidArgumentError("give either --exposures or --ev, not both");
  }
  std::vector<double> times;
  std::string flag;
  if (!args.exposures_s.empty()) {
    times = args.exposures_s;
    flag = "--exposures";
  } else if (!args.ev.empty()) {
    times = ExposureTimesFromEv(args.ev);
    flag = "--ev";
  } else if (from_metadata.size() == count &&
             std::all_of(from_metadata.begin(), from_metadata.end(), [](double t) { return t > 0.0; })) {
    return from_metadata;
  } else {
    throw InvalidArgumentError("exposures unknown: give --exposures (seconds) or --ev (stops), one per file");
  }
  if (times.size() != count) {
    throw InvalidArgumentError(flag + ": " + std::to_string(times.size()) + " value(s) for " + std::to_string(count) +
                               " file(s); give one per file, in the same order");
  }
  for (double t : times) {
    if (!(t > 0.0) || !std::isfinite(t)) throw InvalidArgumentError(flag + ": exposure times must be positive");
  }
  return times;
}

void RunCalibrateResponse(const CalibrateResponseArgs& args_in, std::ostream& out) {
  CalibrateResponseArgs args = args_in;
  {
    std::vector<std::string> inputs = args.files;
    inputs.push_back(args.source.session.empty()
                         ? ""
                         : (std::filesystem::path(args.source.session) / capture::kSessionDatabaseName).string());
    CheckOutputs({{"--out", args.out},
                  {"--plot", args.plot.empty() ? WithoutJson(args.out) + ".png" : args.plot},
                  {"--out (its report)", WithoutJson(args.out) + "_report.json"}},
                 inputs);
  }
  std::vector<CameraImage> frames;
  std::vector<capture::FrameRecord> records;
  if (!args.source.session.empty()) {
    if (!args.files.empty()) throw InvalidArgumentError("calibrate response: give files or --session, not both");
    const capture::SessionReader reader(args.source.session);
    records = SessionFrames(reader, args.source);
    const bool ev_only = std::isnan(records.front().exposure.exposure_time_s);
    for (const capture::FrameRecord& f : records) {
      frames.push_back(reader.LoadImage(f));
      args.files.push_back((reader.dir() / f.file_path).string());
    }
    if (args.exposure.exposures_s.empty() && args.exposure.ev.empty()) {
      for (const capture::FrameRecord& f : records) {
        if (ev_only) {
          args.exposure.ev.push_back(f.exposure.ev_compensation);
        } else {
          const double iso = std::isfinite(f.exposure.iso) && f.exposure.iso > 0.0 ? f.exposure.iso / 100.0 : 1.0;
          args.exposure.exposures_s.push_back(f.exposure.exposure_time_s * iso);
        }
      }
    }
    if (frames.front().encoding == SampleEncoding::kSensorLinear) {
      throw InvalidArgumentError("--frames " + args.source.frames +
                                 ": these are sensor-linear (raw) frames, which need no response curve");
    }
  } else {
    for (const auto& f : args.files) frames.push_back(LoadFrame(f).image);
  }
  if (frames.size() < 2) throw InvalidArgumentError("calibrate response: give at least 2 images of one bracket");
  ResponseOptions options;
  options.method = ResponseMethodFromString(args.method);
  options.sample_count = args.samples;
  options.lambda = args.lambda;
  options.smoothness = ResponseSmoothnessFromString(args.smoothness);
  ResponseResult result;
  std::vector<double> times;
  if (!args.exposure.ev.empty() && args.exposure.exposures_s.empty()) {
    if (args.exposure.ev.size() != frames.size()) {
      throw InvalidArgumentError("--ev: " + std::to_string(args.exposure.ev.size()) + " value(s) for " +
                                 std::to_string(frames.size()) + " file(s)");
    }
    EvCalibration ev = RecoverResponseFromEv(frames, args.exposure.ev, options);
    result = ev.result;
    times = ev.exposure_times_s;
  } else {
    times = ResolveExposures(args.exposure, frames.size());
    result = RecoverResponse(frames, times, options);
  }
  out << "response: " << result.summary.BriefReport() << "\n";
  if (!result.summary.usable) {
    throw InvalidArgumentError("the response could not be recovered: " + result.summary.reason);
  }
  CalibrationProfile profile;
  profile.camera =
      records.empty() ? std::filesystem::path(args.files.front()).stem().string() : records.front().device_id;
  profile.response = result.response;
  SaveProfile(profile, args.out);
  if (!records.empty()) StoreEverywhere(args.source, "response", profile, records, out);
  const std::string plot = args.plot.empty() ? WithoutJson(args.out) + ".png" : args.plot;
  SaveImage(PlotResponse(result.response), plot);
  const std::string report = WithoutJson(args.out) + "_report.json";
  nlohmann::json j = {
      {"method", ToString(result.summary.method)},
      {"usable", result.summary.usable},
      {"converged", result.summary.converged},
      {"iterations", result.summary.iterations},
      {"residual", result.summary.residual},
      {"condition", result.summary.condition},
      {"smoothness", ToString(options.smoothness)},
      {"prior_disagreement", result.summary.prior_disagreement ? nlohmann::json(*result.summary.prior_disagreement)
                                                               : nlohmann::json(nullptr)},
      {"low_confidence", result.summary.low_confidence},
      {"samples_used", result.summary.samples_used},
      {"frames", result.summary.frames_used},
      {"reason", result.summary.reason},
      {"exposure_times_s", times},
      {"files", args.files}};
  std::ofstream(report) << j.dump(1) << "\n";
  out << "wrote " << args.out << ", " << plot << ", " << report << "\n";
}

namespace {

// The chart report's folder: --report-dir, or the profile's path with "_report".
std::string ChartReportDir(const CalibrateChartArgs& args) {
  return args.report_dir.empty() ? WithoutJson(args.out) + "_report" : args.report_dir;
}

// --corners has 8 numbers, and no output would overwrite an input.
void CheckChartArgs(const CalibrateChartArgs& args) {
  if (!args.corners.empty() && args.corners.size() != 8) {
    throw InvalidArgumentError("--corners: give 8 numbers x0,y0,x1,y1,x2,y2,x3,y3");
  }
  const std::string dir = ChartReportDir(args);
  const std::string session_db =
      args.source.session.empty()
          ? ""
          : (std::filesystem::path(args.source.session) / capture::kSessionDatabaseName).string();
  CheckOutputs({{"--out", args.out},
                {"--report-dir", dir + "/chart_detected.png"},
                {"--report-dir", dir + "/swatches.png"},
                {"--report-dir", dir + "/chart_report.json"}},
               {args.image, args.profile, args.reference, args.corners_file, session_db});
}

// What the patches are measured on, and an 8-bit preview to detect and draw on.
struct ChartInput {
  ChartImage chart;
  cv::Mat preview;
  std::string gain_input = "radiance";
  std::vector<capture::FrameRecord> records;  // the session's frames; none for an image file
};

// The chart from a session's frames, merged to radiance with the profile's response, else the
// session's recorded one.
ChartInput ChartFromSession(const CalibrateChartArgs& args, const std::optional<CalibrationProfile>& base,
                            std::ostream& out) {
  ChartInput in;
  const capture::SessionReader reader(args.source.session);
  in.records = SessionFrames(reader, args.source);
  std::optional<CameraResponse> response;
  if (base && base->response) {
    response = base->response;
  } else if (const auto recorded = pipeline::SessionCalibration(reader, in.records.front().device_id, "response")) {
    response = recorded->first.response;
  }
  const pipeline::LinearisedBracket linear =
      pipeline::LineariseBracket(reader, in.records, response, std::nullopt, HdrMergeOptions{}, ResponseOptions{});
  out << "chart image: " << in.records.size() << " frame(s) of " << in.records.front().device_id << " merged ("
      << linear.response_source << " response)\n";
  in.chart.values = linear.radiance.pixels;
  in.preview = PreviewLinear(linear.radiance.pixels);
  return in;
}

// The chart from an image file: EXR radiance, or a camera frame linearised with the profile's
// response (or its exposure when sensor-linear; else gains apply to normalised codes).
ChartInput ChartFromImage(const CalibrateChartArgs& args, const std::optional<CalibrationProfile>& base) {
  ChartInput in;
  const std::string ext = std::filesystem::path(args.image).extension().string();
  if (ext == ".exr" || ext == ".EXR") {
    const RadianceImage radiance = LoadRadianceExr(args.image);
    if (radiance.pixels.channels() != 3) throw InvalidArgumentError(args.image + ": the chart image must be RGB");
    in.chart.values = radiance.pixels;
    in.preview = PreviewLinear(radiance.pixels);
    return in;
  }
  const CameraImage image = LoadFrame(args.image).image;
  if (image.layout != ColorLayout::kRgb) throw InvalidArgumentError(args.image + ": the chart image must be RGB");
  in.chart = ChartImageFromCamera(image);
  if (base && base->response) {
    CalibrationProfile linearise;
    linearise.response = base->response;
    in.chart.values = ApplyProfile(linearise, image, args.exposure_s).pixels;
  } else if (image.encoding == SampleEncoding::kSensorLinear) {
    in.chart.values = in.chart.values / args.exposure_s;
  } else {
    in.gain_input = "normalized_code";
  }
  if (image.pixels.depth() == CV_8U) {
    in.preview = image.pixels;
  } else {
    image.pixels.convertTo(in.preview, CV_8U, 255.0 / image.white_level);
  }
  return in;
}

// The chart's corners from --corners or --corners-file, else the detector's.
ChartLocation LocateChart(const CalibrateChartArgs& args, const cv::Mat& preview,
                          const ColorCheckerReference& reference) {
  std::vector<cv::Point2f> corners;
  if (!args.corners.empty()) {
    if (args.corners.size() != 8) throw InvalidArgumentError("--corners: give 8 numbers x0,y0,x1,y1,x2,y2,x3,y3");
    for (int k = 0; k < 4; ++k) {
      corners.emplace_back(static_cast<float>(args.corners[2 * k]), static_cast<float>(args.corners[2 * k + 1]));
    }
  } else if (!args.corners_file.empty()) {
    corners = CornersFromYaml(args.corners_file);
  }
  if (!corners.empty()) return ChartFromCorners(corners, preview, reference);
  ChartDetectOptions options;
  options.detector = ChartDetectorFromString(args.detector);
  ChartLocation location = DetectColorChecker(preview, reference, options);
  if (!location.found) {
    throw InvalidArgumentError("no ColorChecker found in " + args.image + " (" + location.reason +
                               "); give its corners with --corners x0,y0,...");
  }
  return location;
}

// The report in `dir`: chart_detected.png, swatches.png and chart_report.json (detection, fit,
// per patch its measurement and colour error).
void WriteChartReport(const std::string& dir, const std::string& image, const cv::Mat& preview,
                      const ChartLocation& location, const std::vector<PatchSample>& patches, const ColorFit& fit,
                      const ColorCheckerReference& reference) {
  std::filesystem::create_directories(dir);
  SaveImage(DrawChart(preview, location, patches), dir + "/chart_detected.png");
  SaveImage(DrawSwatches(fit, reference), dir + "/swatches.png");
  nlohmann::json j;
  j["image"] = image;
  j["detection"] = {
      {"method", location.method}, {"orientation_score", location.orientation_score}, {"reason", location.reason}};
  for (const auto& c : location.corners) j["detection"]["corners"].push_back({c.x, c.y});
  j["fit"] = {{"usable", fit.summary.usable},
              {"low_confidence", fit.summary.low_confidence},
              {"patches_used", fit.summary.patches_used},
              {"condition", fit.summary.condition},
              {"residual_rms", fit.summary.residual_rms},
              {"mean_delta_e_2000", fit.summary.mean_delta_e},
              {"max_delta_e_2000", fit.summary.max_delta_e},
              {"reason", fit.summary.reason}};
  for (int k = 0; k < 24; ++k) {
    const PatchFit& p = fit.patches[k];
    j["patches"].push_back(
        {{"name", reference.patches[k].name},
         {"status", ToString(p.status)},
         {"used", p.used},
         {"measured", {p.measured[0], p.measured[1], p.measured[2]}},
         {"corrected_lab", {p.corrected_lab[0], p.corrected_lab[1], p.corrected_lab[2]}},
         {"reference_lab",
          {reference.patches[k].lab_d50[0], reference.patches[k].lab_d50[1], reference.patches[k].lab_d50[2]}},
         {"delta_e_2000", p.delta_e}});
  }
  std::ofstream(dir + "/chart_report.json") << j.dump(1) << "\n";
}

}  // namespace

void RunCalibrateChart(const CalibrateChartArgs& args, std::ostream& out) {
  CheckChartArgs(args);
  const ColorCheckerReference reference = LoadColorCheckerReference(args.reference);
  std::optional<CalibrationProfile> base;
  if (!args.profile.empty()) base = LoadProfile(args.profile);
  ChartInput input;
  if (!args.source.session.empty()) {
    if (!args.image.empty()) throw InvalidArgumentError("calibrate chart: give an image or --session, not both");
    input = ChartFromSession(args, base, out);
  } else if (args.image.empty()) {
    throw InvalidArgumentError("calibrate chart: give the chart image, or --session DIR --frames SELECTOR");
  } else {
    input = ChartFromImage(args, base);
  }
  const ChartLocation location = LocateChart(args, input.preview, reference);
  out << "chart: found by " << location.method << ", orientation score " << location.orientation_score << "\n";
  const std::vector<PatchSample> patches = SamplePatches(input.chart, location);
  ColorFitOptions fit_options;
  fit_options.white_preserving = args.white_preserving;
  const ColorFit fit = FitColorChecker(patches, reference, fit_options);
  out << "fit: " << fit.summary.BriefReport() << "\n";
  if (!fit.summary.usable) throw InvalidArgumentError("the chart fit failed: " + fit.summary.reason);

  CalibrationProfile profile = base.value_or(CalibrationProfile{});
  if (!input.records.empty()) profile.camera = input.records.front().device_id;
  if (profile.camera.empty()) profile.camera = std::filesystem::path(args.image).stem().string();
  profile.gain_input = input.gain_input;
  profile.gain = fit.gain;
  profile.ccm = fit.ccm;
  profile.fit = fit.summary;
  SaveProfile(profile, args.out);
  if (!input.records.empty()) StoreEverywhere(args.source, "profile", profile, input.records, out);

  const std::string dir = ChartReportDir(args);
  WriteChartReport(dir, args.image, input.preview, location, patches, fit, reference);
  out << "wrote " << args.out << " and " << dir << "/{chart_detected.png, swatches.png, chart_report.json}\n";
}

struct CalibrateIntrinsicsArgs {
  SessionSource source;
  std::string board = "9x6";
  std::string charuco;  // SQUARESxSQUARES: a ChArUco board instead of --board's chessboard
  double square_m = 0.025;
  double marker_m = 0.0;  // ChArUco marker side (0: 0.75 of the square)
  std::string dictionary = "4x4_50";
  std::string distortion = "none";
};

// The intrinsics from the frames' board: a ChArUco board with --charuco, else a chessboard; `what`
// describes the board for the scene model's record.
calibration::IntrinsicsResult BoardIntrinsics(const CalibrateIntrinsicsArgs& args, const std::vector<cv::Mat>& images,
                                              std::string* what) {
  if (!args.charuco.empty()) {
    calibration::CharucoOptions options;
    if (std::sscanf(args.charuco.c_str(), "%dx%d", &options.squares_x, &options.squares_y) != 2) {
      throw InvalidArgumentError("--charuco " + args.charuco + ": expected squares as COLSxROWS, e.g. 7x5");
    }
    options.square_m = args.square_m;
    options.marker_m = args.marker_m > 0.0 ? args.marker_m : 0.75 * args.square_m;
    options.dictionary = args.dictionary;
    options.distortion = args.distortion;
    ThrowIfInvalid(options, "--charuco/--square/--marker/--dictionary/--distortion");
    *what = "ChArUco views (" + args.charuco + " squares of " + std::to_string(args.square_m) + " m, markers " +
            std::to_string(options.marker_m) + " m, " + args.dictionary;
    return calibration::CalibrateIntrinsicsCharuco(images, options);
  }
  calibration::ChessboardOptions options;
  if (std::sscanf(args.board.c_str(), "%dx%d", &options.inner_cols, &options.inner_rows) != 2) {
    throw InvalidArgumentError("--board " + args.board + ": expected inner corners as COLSxROWS, e.g. 9x6");
  }
  options.square_m = args.square_m;
  options.distortion = args.distortion;
  ThrowIfInvalid(options, "--board/--square/--distortion");
  *what = "chessboard views (" + args.board + " inner corners, " + std::to_string(args.square_m) + " m squares";
  return calibration::CalibrateIntrinsics(images, options);
}

// A camera's intrinsics from chessboard or ChArUco frames of a session (calibration/intrinsics.h),
// stored in the session's scene model: the camera's pose, when the model has one, is kept.
void RunCalibrateIntrinsics(const CalibrateIntrinsicsArgs& args, std::ostream& out) {
  const capture::SessionReader reader(args.source.session);
  const std::vector<capture::FrameRecord> frames = SessionFrames(reader, args.source);
  std::vector<cv::Mat> images;
  for (const capture::FrameRecord& f : frames) images.push_back(calibration::ChessboardImage(reader.LoadImage(f)));
  std::string what;
  const calibration::IntrinsicsResult result = BoardIntrinsics(args, images, &what);
  const std::string device = frames.front().device_id;
  const std::optional<SceneModel> model = capture::LatestSceneModel(args.source.session);
  SceneModelCamera camera;
  camera.has_pose = false;
  if (const SceneModelCamera* known = model ? model->FindCamera(device) : nullptr) camera = *known;
  camera.device_id = device;
  camera.camera.intrinsics = result.intrinsics;
  camera.distortion = result.distortion;
  camera.reprojection_error_px = result.rms_px;
  camera.source = "intrinsics from " + std::to_string(result.views_used.size()) + " " + what + ", --frames " +
                  args.source.frames + ")" + (camera.has_pose ? "; pose kept from before" : "; no pose yet");
  const std::int64_t row = capture::SetSceneModelCamera(args.source.session, camera);
  out << device << ": " << result.Report() << "\n";
  for (std::size_t i = 0; i < result.views_used.size(); ++i) {
    out << "  frame " << frames[static_cast<std::size_t>(result.views_used[i])].id << ": " << result.view_rms_px[i]
        << " px\n";
  }
  for (int i : result.views_without_board) {
    out << "  frame " << frames[static_cast<std::size_t>(i)].id
        << (args.charuco.empty() ? ": no whole board found (not used)\n"
                                 : ": too few board corners found (not used)\n");
  }
  out << "stored in " << args.source.session << " as scene model row " << row << "\n";
}

struct CalibratePoseArgs {
  std::string session;
  std::string device;
  std::string gcp;
  std::string markers;  // surveyed ArUco markers instead of --gcp
  std::string dictionary = "4x4_50";
  std::int64_t frame_id = 0;  // with --markers: the frame to detect them in (0: the best of the device's)
  std::string gcp_frame = "enu";
  int utm_zone = 0;
  double fov_deg = 0.0;
  double threshold_px = 3.0;
};

// The corners of surveyed markers (--markers) detected in one of the device's frames, as ground
// control points: frame --frame, else the frame of the device that shows the most of them. `from`
// says where they came from, for the scene model's record.
std::vector<calibration::GroundControlPoint> MarkerPoints(const capture::SessionReader& reader,
                                                          const std::vector<capture::FrameRecord>& frames,
                                                          const CalibratePoseArgs& args, std::string* from,
                                                          std::ostream& out) {
  const std::vector<calibration::SurveyedMarker> markers =
      calibration::LoadMarkerFile(args.markers, args.gcp_frame, reader.info().site, args.utm_zone);
  std::vector<calibration::GroundControlPoint> best;
  std::vector<int> best_unsurveyed;
  std::int64_t best_id = 0;
  int searched = 0;
  for (const capture::FrameRecord& f : frames) {
    if (f.device_id != args.device || f.width <= 0 || (args.frame_id != 0 && f.id != args.frame_id)) continue;
    ++searched;
    const std::vector<calibration::MarkerDetection> found =
        calibration::DetectMarkers(calibration::ChessboardImage(reader.LoadImage(f)), args.dictionary);
    std::vector<int> unsurveyed;
    std::vector<calibration::GroundControlPoint> points = calibration::MarkerControlPoints(found, markers, &unsurveyed);
    if (points.size() > best.size()) {
      best = std::move(points);
      best_unsurveyed = unsurveyed;
      best_id = f.id;
    }
  }
  if (searched == 0) {
    throw InvalidArgumentError("frame " + std::to_string(args.frame_id) + " is not a decoded frame of device '" +
                               args.device + "' (`relume session info` lists the frames)");
  }
  if (best.empty()) {
    throw InvalidArgumentError("none of the " + std::to_string(markers.size()) + " markers of " + args.markers +
                               " was found in " + std::to_string(searched) + " frame(s) of " + args.device +
                               " (dictionary " + args.dictionary + "; check --dictionary and the marker ids)");
  }
  out << "frame " << best_id << ": " << best.size() / 4 << " of " << markers.size() << " surveyed markers found";
  if (!best_unsurveyed.empty()) {
    out << "; ids not in " << args.markers << ":";
    for (int id : best_unsurveyed) out << " " << id;
  }
  out << "\n";
  *from = " corners of surveyed markers (" + args.markers + ", " + args.gcp_frame + ", " + args.dictionary +
          ") detected in frame " + std::to_string(best_id);
  return best;
}

// A camera's pose from ground control points (calibration/camera_pose.h), stored in the
// session's scene model (capture/scene_model_record.h). Intrinsics: the scene model's camera of
// the device, or --fov with the device's frame size.
void RunCalibratePose(const CalibratePoseArgs& args, std::ostream& out) {
  const capture::SessionReader reader(args.session);
  const std::vector<capture::FrameRecord> frames = reader.Frames();
  const auto frame = std::find_if(frames.begin(), frames.end(), [&args](const capture::FrameRecord& f) {
    return f.device_id == args.device && f.width > 0;
  });
  if (frame == frames.end()) {
    throw InvalidArgumentError("session " + args.session + " has no decoded frame of device '" + args.device +
                               "' (`relume session info` lists its devices)");
  }
  SceneModelCamera camera;
  const std::optional<SceneModel> model = capture::LatestSceneModel(args.session);
  const SceneModelCamera* known = model ? model->FindCamera(args.device) : nullptr;
  if (args.fov_deg > 0.0) {
    camera.camera.intrinsics =
        PinholeIntrinsics::FromHorizontalFov(frame->width, frame->height, args.fov_deg * std::numbers::pi / 180.0);
    camera.source = "horizontal field of view " + std::to_string(args.fov_deg) + " deg; ";
  } else if (known != nullptr) {
    camera = *known;
    // Keep where the intrinsics came from ("intrinsics from 10 ChArUco views (...)"); drop the old pose's part.
    const std::string before = known->source.substr(0, known->source.find("; "));
    camera.source = (before.starts_with("intrinsics from") ? before : "intrinsics from the scene model") + "; ";
  } else {
    throw InvalidArgumentError("the pose needs the camera's intrinsics: the session's scene model has no camera '" +
                               args.device + "'; give --fov DEG (the lens's horizontal field of view)");
  }
  camera.device_id = args.device;
  calibration::CameraPoseOptions options;
  options.ransac_threshold_px = args.threshold_px;
  options.distortion = camera.distortion;
  std::string from;
  const std::vector<calibration::GroundControlPoint> points =
      args.markers.empty() ? calibration::LoadGcpFile(args.gcp, args.gcp_frame, reader.info().site, args.utm_zone)
                           : MarkerPoints(reader, frames, args, &from, out);
  if (args.markers.empty()) from = " ground control points in " + args.gcp + " (" + args.gcp_frame + ")";
  const calibration::CameraPoseResult pose = calibration::EstimateCameraPose(points, camera.camera.intrinsics, options);
  camera.camera.world_from_camera = pose.world_from_camera;
  camera.reprojection_error_px = pose.rms_px;
  camera.has_pose = true;
  camera.source += "pose from " + std::to_string(pose.inliers) + " of " + std::to_string(points.size()) + from;
  const std::int64_t row = capture::SetSceneModelCamera(args.session, camera);
  const Eigen::Vector3d eye = pose.world_from_camera.translation();
  out << "camera " << args.device << " at (" << eye.x() << ", " << eye.y() << ", " << eye.z() << ") m ENU; residuals:\n"
      << pose.Report(points) << "stored in " << args.session << " as scene model row " << row << "\n";
}

struct CalibrateRgbdArgs {
  std::string session;
  std::string device;
  std::string frames;  // colour frames to use (default: all of the device's)
  std::string charuco = "7x5";
  double square_m = 0.04;
  double marker_m = 0.0;
  std::string dictionary = "4x4_50";
  double max_gap_ms = 20.0;
};

// The device's colour frames (--frames, default all) each with the depth frame nearest in time
// (within --max-gap-ms).
std::vector<std::pair<capture::FrameRecord, capture::FrameRecord>> RgbdPairs(const capture::SessionReader& reader,
                                                                             const CalibrateRgbdArgs& args) {
  const std::vector<capture::FrameRecord> all = reader.Frames();
  const std::vector<capture::FrameRecord> chosen =
      args.frames.empty() ? all : pipeline::SelectFrames(reader, args.frames);
  std::vector<std::pair<capture::FrameRecord, capture::FrameRecord>> pairs;
  for (const capture::FrameRecord& c : chosen) {
    if (c.device_id != args.device || c.stream != "color") continue;
    const capture::FrameRecord* best = nullptr;
    for (const capture::FrameRecord& d : all) {
      if (d.device_id != c.device_id || d.stream != "depth") continue;
      if (best == nullptr || std::chrono::abs(d.utc - c.utc) < std::chrono::abs(best->utc - c.utc)) best = &d;
    }
    if (best != nullptr &&
        std::chrono::duration<double, std::milli>(std::chrono::abs(best->utc - c.utc)).count() <= args.max_gap_ms) {
      pairs.emplace_back(c, *best);
    }
  }
  if (pairs.empty()) {
    throw InvalidArgumentError("no colour frame of '" + args.device + "'" +
                               (args.frames.empty() ? "" : " among --frames " + args.frames) +
                               " has a depth frame within " + std::to_string(args.max_gap_ms) +
                               " ms (`relume session info` lists the devices and streams)");
  }
  return pairs;
}

// An RGB-D sensor's depth-to-colour transform from frames of a ChArUco board
// (calibration/rgbd_extrinsics.h), stored as a new rgbd_geometry row: the recorded geometry with
// this transform, applying to the frames the recorded row applied to, so that processing
// registers the depth with it.
void RunCalibrateRgbd(const CalibrateRgbdArgs& args, std::ostream& out) {
  const capture::SessionReader reader(args.session);
  const auto pairs = RgbdPairs(reader, args);
  const std::vector<capture::CalibrationRecord> rows = reader.Calibrations();
  const capture::CalibrationRecord* base = capture::RgbdGeometryAt(rows, args.device, pairs.front().second.id);
  if (base == nullptr) {
    throw InvalidArgumentError("the session records no geometry (rgbd_geometry row) of " + args.device +
                               "; its intrinsics are needed first");
  }
  drivers::RgbdFrame geometry;
  capture::ApplyRgbdGeometryJson(base->json, &geometry);
  if (geometry.registered_to_color) {
    throw InvalidArgumentError(args.device +
                               " recorded depth registered to colour: the sensor applied its own transform, and "
                               "relume does not use one for registered depth");
  }
  calibration::RgbdExtrinsicsOptions options;
  if (std::sscanf(args.charuco.c_str(), "%dx%d", &options.board.squares_x, &options.board.squares_y) != 2) {
    throw InvalidArgumentError("--charuco " + args.charuco + ": expected squares as COLSxROWS, e.g. 7x5");
  }
  options.board.square_m = args.square_m;
  options.board.marker_m = args.marker_m > 0.0 ? args.marker_m : 0.75 * args.square_m;
  options.board.dictionary = args.dictionary;
  ThrowIfInvalid(options, "--charuco/--square/--marker/--dictionary");
  std::vector<cv::Mat> colour, depth;
  for (const auto& [c, d] : pairs) {
    colour.push_back(calibration::ChessboardImage(reader.LoadImage(c)));
    depth.push_back(reader.LoadDepth(d));
  }
  const calibration::RgbdExtrinsicsResult result = calibration::CalibrateRgbdExtrinsics(
      colour, depth, geometry.color_intrinsics, geometry.depth_intrinsics, geometry.color_from_depth, options);
  out << args.device << ": " << result.Report() << "\n";
  for (std::size_t i = 0; i < result.views_used.size(); ++i) {
    const auto& pair = pairs[static_cast<std::size_t>(result.views_used[i])];
    out << "  colour frame " << pair.first.id << " + depth " << pair.second.id << ": plane RMS "
        << result.view_plane_rms_m[i] * 1e3 << " mm, normal " << result.view_normal_deg[i] << " deg, distance "
        << result.view_distance_m[i] * 1e3 << " mm\n";
  }
  for (int i : result.views_without_board) {
    out << "  colour frame " << pairs[static_cast<std::size_t>(i)].first.id << ": no usable board (not used)\n";
  }
  geometry.color_from_depth = result.color_from_depth;
  capture::CalibrationRecord record;
  record.created_utc =
      UtcTime(std::chrono::duration_cast<Nanoseconds>(std::chrono::system_clock::now().time_since_epoch()));
  record.kind = capture::kRgbdGeometryKind;
  record.device_id = args.device;
  // The geometry, and where its transform came from with the residuals (ignored by readers of
  // the geometry, shown to people who look at the row).
  nlohmann::json row = nlohmann::json::parse(capture::RgbdGeometryToJson(geometry));
  std::vector<std::int64_t> used_frames;
  for (int i : result.views_used) used_frames.push_back(pairs[static_cast<std::size_t>(i)].first.id);
  row["calibration"] = {
      {"method", "ChArUco plane-to-plane (calibration/rgbd_extrinsics.h)"},
      {"board", args.charuco + " squares of " + std::to_string(args.square_m) + " m, " + args.dictionary},
      {"colour_frames", used_frames},
      {"plane_rms_m", result.view_plane_rms_m},
      {"normal_residual_deg", result.view_normal_deg},
      {"distance_residual_m", result.view_distance_m},
      {"normal_spread_deg", result.normal_spread_deg}};
  record.json = row.dump();
  record.source_frame_ids = base->source_frame_ids;  // applies where the recorded row did
  const std::int64_t id = capture::SessionWriter::Append(args.session)->AddCalibration(record);
  out << "stored in " << args.session << " as calibration " << id << " (rgbd_geometry of " << args.device
      << "; the sh pipeline registers depth with it)\n";
}

// `relume calibrate rgbd`.
void AddCalibrateRgbd(CLI::App* calibrate) {
  auto g = std::make_shared<CalibrateRgbdArgs>();
  CLI::App* rgbd = calibrate->add_subcommand(
      "rgbd", "An RGB-D sensor's depth-to-colour transform from frames of a ChArUco board; stored in the session");
  rgbd->add_option("--session", g->session, "The session with the board frames")->required();
  rgbd->add_option("--device", g->device, "The RGB-D device id (`relume session info`)")->required();
  rgbd->add_option("--frames", g->frames, "Colour frames to use (an id, a range 3-12, DEVICE:color; default all)");
  rgbd->add_option("--charuco", g->charuco, "The ChArUco board's squares COLSxROWS")->capture_default_str();
  rgbd->add_option("--square", g->square_m, "Square size (m)")->capture_default_str();
  rgbd->add_option("--marker", g->marker_m, "Marker side (m; default 0.75 of --square)");
  rgbd->add_option("--dictionary", g->dictionary, "The markers' ArUco dictionary")->capture_default_str();
  rgbd->add_option("--max-gap-ms", g->max_gap_ms, "Largest time gap of a colour and a depth frame paired (ms)")
      ->capture_default_str();
  rgbd->callback([g]() { RunCalibrateRgbd(*g, std::cout); });
}

void AddCalibrateCommand(CLI::App& app) {
  CLI::App* calibrate = app.add_subcommand("calibrate",
                                           "Calibration: camera response, ColorChecker, intrinsics (chessboard, "
                                           "ChArUco), a camera's pose (control points, markers)");
  calibrate->require_subcommand(1);

  auto r = std::make_shared<CalibrateResponseArgs>();
  CLI::App* response = calibrate->add_subcommand("response", "Recover the camera response from an exposure bracket");
  response->add_option("files", r->files, "Bracket images of a static scene (8-bit, same size)");
  response->add_option("--session", r->source.session,
                       "Take the bracket from this session (and store the result in it)");
  response->add_option("--frames", r->source.frames, "With --session: the frames (bracket:N, ids, DEVICE:still)");
  response->add_option("--store-in", r->source.store_in, "With --session: also store the response in these sessions");
  response->add_option("--exposures", r->exposure.exposures_s, "Exposure times in seconds, one per file")
      ->delimiter(',');
  response->add_option("--ev", r->exposure.ev, "EV values (EV-only cameras), one per file")->delimiter(',');
  response->add_option("--method", r->method, "debevec or robertson")->capture_default_str();
  response->add_option("--samples", r->samples, "Pixels sampled (Debevec; Robertson uses 20x)")->capture_default_str();
  response->add_option("--lambda", r->lambda, "Debevec smoothness weight")->capture_default_str();
  response
      ->add_option("--smoothness", r->smoothness,
                   "Debevec smoothness term: code (g'') or log-code (d2g/d(ln z)^2, exact for power laws)")
      ->capture_default_str();
  response->add_option("--out", r->out, "Profile JSON to write")->capture_default_str();
  response->add_option("--plot", r->plot, "PNG plot of the curves (default: beside --out)");
  response->callback([r]() { RunCalibrateResponse(*r, std::cout); });

  auto c = std::make_shared<CalibrateChartArgs>();
  CLI::App* chart = calibrate->add_subcommand("chart", "Find a ColorChecker, fit gain and colour matrix");
  chart->add_option("image", c->image, "Image of the chart (PNG/TIFF camera output, raw, or EXR radiance)");
  chart->add_option("--session", c->source.session, "Take the chart from this session (and store the profile in it)");
  chart->add_option("--frames", c->source.frames, "With --session: the chart's frames (bracket:N or a frame id)");
  chart->add_option("--store-in", c->source.store_in, "With --session: also store the profile in these sessions");
  chart->add_option("--corners", c->corners, "Chart corners x0,y0,...,x3,y3 (pixels), instead of detection")
      ->delimiter(',');
  chart->add_option("--corners-file", c->corners_file, "YAML with corners: [[x, y], ...]");
  chart->add_option("--detector", c->detector, "auto, mcc or lattice")->capture_default_str();
  chart->add_option("--profile", c->profile, "Profile with a response to linearise the image first");
  chart->add_option("--exposure", c->exposure_s, "Exposure time of the image in seconds")->capture_default_str();
  chart->add_option("--reference", c->reference, "Chart reference data (YAML)")->capture_default_str();
  chart->add_flag("!--no-white-preserving", c->white_preserving, "Fit the colour matrix without the white constraint");
  chart->add_option("--out", c->out, "Profile JSON to write")->capture_default_str();
  chart->add_option("--report-dir", c->report_dir, "Folder for the report (default: beside --out)");
  chart->callback([c]() { RunCalibrateChart(*c, std::cout); });

  auto in = std::make_shared<CalibrateIntrinsicsArgs>();
  CLI::App* intrinsics = calibrate->add_subcommand(
      "intrinsics", "A camera's intrinsics from chessboard frames; stored in the session's scene model");
  intrinsics->add_option("--session", in->source.session, "The session with the chessboard frames")->required();
  intrinsics
      ->add_option("--frames", in->source.frames, "The board frames (an id, a range 3-12, bracket:N, DEVICE:still)")
      ->required();
  intrinsics->add_option("--board", in->board, "Inner corners COLSxROWS (a 10x7-square board has 9x6)")
      ->capture_default_str();
  intrinsics->add_option("--charuco", in->charuco, "A ChArUco board of COLSxROWS squares instead of --board");
  intrinsics->add_option("--square", in->square_m, "Square size (m)")->capture_default_str();
  intrinsics->add_option("--marker", in->marker_m, "ChArUco marker side (m; default 0.75 of --square)");
  intrinsics->add_option("--dictionary", in->dictionary, "ChArUco markers' ArUco dictionary (4x4_50, 5x5_100, ...)")
      ->capture_default_str();
  intrinsics
      ->add_option("--distortion", in->distortion,
                   "none (pinhole), radial (k1, k2) or full; irm, radiosity and sh undistort frames with it")
      ->capture_default_str();
  intrinsics->callback([in]() { RunCalibrateIntrinsics(*in, std::cout); });

  AddCalibrateRgbd(calibrate);

  auto p = std::make_shared<CalibratePoseArgs>();
  CLI::App* pose = calibrate->add_subcommand("pose",
                                             "A camera's pose in the site frame from ground control points or surveyed "
                                             "ArUco markers; stored in the session's scene model");
  pose->add_option("--session", p->session, "The session (its site, and where the pose is stored)")->required();
  pose->add_option("--device", p->device, "The camera's device id (`relume session info`)")->required();
  CLI::Option* gcp = pose->add_option("--gcp", p->gcp, "CSV: name,u,v,a,b,c (pixels; a, b, c in --gcp-frame)");
  CLI::Option* markers = pose->add_option(
      "--markers", p->markers,
      "CSV of surveyed ArUco markers: id,corner,a,b,c (corners 0-3 top-left, top-right, bottom-right, bottom-left "
      "as printed; a, b, c in --gcp-frame), detected in the device's frames");
  gcp->excludes(markers);
  pose->add_option("--dictionary", p->dictionary, "The markers' ArUco dictionary")->capture_default_str();
  pose->add_option("--frame", p->frame_id, "With --markers: the frame id to detect them in (default: the best)");
  pose->add_option("--gcp-frame", p->gcp_frame,
                   "enu (m at the site), utm (easting, northing, height) or wgs84 "
                   "(lat, lon deg, ellipsoidal height)")
      ->capture_default_str();
  pose->add_option("--utm-zone", p->utm_zone, "UTM zone of --gcp-frame utm (0: the site's)")->capture_default_str();
  pose->add_option("--fov", p->fov_deg, "Horizontal field of view (deg), when the scene model has no intrinsics");
  pose->add_option("--threshold", p->threshold_px, "A point further than this (px) is an outlier")
      ->capture_default_str();
  pose->callback([p]() {
    if (p->gcp.empty() == p->markers.empty()) {
      throw InvalidArgumentError("relume calibrate pose: give --gcp (marked pixels) or --markers (surveyed markers)");
    }
    RunCalibratePose(*p, std::cout);
  });
}

}  // namespace relume::app
