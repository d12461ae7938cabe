// `relume process --pipeline sh` end to end: small simulated RGB-D sessions (320x240, four
// frames, tests/data/rigs/sim-sh-*.yaml) are captured with the binary, processed, and the
// relit frames are compared with the world's truth under the destination light; stage reuse
// and the planner's decisions are checked from summary.json.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <optional>
#include <sstream>
#include <string>

#include "calibration/image_file.h"
#include "calibration/testing/lens.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/image.h"
#include "tests/apps/cli_runner.h"
#include "tests/apps/lens_copy.h"

namespace relume::pipeline {
namespace {
namespace fs = std::filesystem;
using relume::testing::ReadJsonFile;
using relume::testing::RunRelume;

const std::string kSource = RELUME_SOURCE_DIR;

fs::path TempDir(const std::string& name) {
  return relume::testing::FreshTempDir("sh_test", name);
}

fs::path Capture(const fs::path& root, const std::string& rig) {
  const fs::path session = root / "session";
  const auto r = RunRelume("capture --rig " + kSource + "/tests/data/rigs/" + rig + " --out " + session.string() +
                           " --no-progress");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return session;
}

nlohmann::json Process(const fs::path& session, const fs::path& out, const std::string& extra = "") {
  const auto r = RunRelume("process " + session.string() + " --pipeline sh --out " + out.string() + " " + extra);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return ReadJsonFile(out / "summary.json");
}

// Actions of the cached stages ("radiance-2" -> "run"), by stage name.
std::map<std::string, std::string> StageActions(const nlohmann::json& summary) {
  std::map<std::string, std::string> actions;
  for (const nlohmann::json& d : summary["decisions"]) {
    const std::string stage = d["stage"];
    const std::string action = d["action"];
    if (action == "run" || action == "reuse") {
      if (stage.find('-') != std::string::npos) actions[stage] = action;
    }
  }
  return actions;
}

// The relit frames against the destination frame's photograph (no truth needed) measure what
// the truth does: the median over frames within `tolerance` of the mean error against the truth.
void ExpectPhotographTracksTheTruth(const nlohmann::json& metrics, double tolerance) {
  ASSERT_TRUE(metrics.contains("destination_photo_relative_rms_median")) << metrics.dump(1);
  ASSERT_TRUE(metrics.contains("relit_relative_rms_mean")) << metrics.dump(1);
  EXPECT_NEAR(metrics["destination_photo_relative_rms_median"].get<double>(),
              metrics["relit_relative_rms_mean"].get<double>(), tolerance);
}

int CountDecisions(const nlohmann::json& summary, const std::string& stage, const std::string& action) {
  int n = 0;
  for (const nlohmann::json& d : summary["decisions"]) n += d["stage"] == stage && d["action"] == action;
  return n;
}

TEST(ShPipelineCliTest, StaticObjectUnderAMovingLightIsRelitCloseToTheTruthAndStagesAreReused) {
  const fs::path root = TempDir("moving_light");
  const fs::path session = Capture(root, "sim-sh-moving-light-ideal.yaml");
  const fs::path out = root / "out";
  const nlohmann::json first = Process(session, out);
  const nlohmann::json& m = first["metrics"];
  // Destination: the last frame's estimate; truth: the world rendered at that frame's time.
  ASSERT_EQ(m["compared_frames"], 3) << m.dump(1);
  const double relit = m["relit_relative_rms_mean"];
  const double baseline = m["baseline_relative_rms_mean"];
  // The goal, relit <= 2 % on noise-free Lambertian input: measured 1.62 % with the albedo
  // unknown (the default since 2026-12-03), 1.66 % with the world's as an oracle: SH-9 light model
  // (1.55 % with true normals) + normals (2.14 % before the ideal rig registered depth by
  // interpolation and stored it in metres, and before noise-free depth skipped the filters;
  // 1.89 % before the normals beside creases were refined; 1.76 % before the relighting ratio
  // was filtered).
  EXPECT_LT(relit, 0.02);
  EXPECT_EQ(CountDecisions(first, "denoise", "skip"), 1);
  EXPECT_GT(baseline, 0.08);
  EXPECT_LT(relit, baseline / 4.0);
  EXPECT_LT(m["irradiance_relative_rms_mean"].get<double>(), 0.05);
  for (const nlohmann::json& f : m["frames"]) {
    EXPECT_EQ(f["fit"]["order_used"], 2);  // three objects cover ~3.8 sr: order 2 is supported
    EXPECT_TRUE(f["fit"]["usable"]);
  }
  // The report shows the RGB-D sensor's recorded geometry as such (it was once read as a colour
  // profile and reported as an error).
  {
    std::ifstream page(out / "report.html");
    std::ostringstream html;
    html << page.rdbuf();
    EXPECT_EQ(html.str().find("cannot be read"), std::string::npos);
    EXPECT_NE(html.str().find("depth registered to colour"), std::string::npos);
  }
  // SH describes this light (fit residual ~3 %): no warning. Asked to be stricter than the
  // residual (a report-only knob), it says SH does not fit, reusing every stage.
  EXPECT_TRUE(m["sh_fits_scene"].get<bool>()) << m["fit_residual_median"];
  EXPECT_LT(m["fit_residual_median"].get<double>(), 0.05);
  EXPECT_EQ(CountDecisions(first, "sh-model", "warn"), 0);
  EXPECT_LT(m["cast_shadows"]["removed_share_median"].get<double>(), 0.01);  // nothing shadows the objects
  // The static view shows the same surfaces in every frame: the relit frames against the
  // destination frame's photograph, no truth needed, measure what the truth does (1.5 % / 1.6 %).
  ASSERT_EQ(m["destination_photo_frames"], 3) << m.dump(1);
  const double photo = m["destination_photo_relative_rms_median"];
  EXPECT_LT(photo, 0.025);
  EXPECT_NEAR(photo, relit, 0.005);
  for (const nlohmann::json& f : m["frames"]) {
    if (!f.contains("relight")) continue;
    EXPECT_GT(f["destination_photo_pixels"].get<std::int64_t>(), f["relight"]["relit"].get<std::int64_t>() / 2) << f;
  }
  EXPECT_NE(first["headline"].get<std::string>().find("relit vs the destination photograph"), std::string::npos);
  const nlohmann::json strict = Process(session, out, "--set max_fit_residual=0.01");
  EXPECT_EQ(CountDecisions(strict, "sh-model", "warn"), 1);
  EXPECT_FALSE(strict["metrics"]["sh_fits_scene"].get<bool>());
  EXPECT_NE(strict["headline"].get<std::string>().find("SH DOES NOT FIT"), std::string::npos) << strict["headline"];
  for (const auto& [stage, action] : StageActions(strict)) EXPECT_EQ(action, "reuse") << stage;
  // Stricter than the photograph's error: that check warns too, from the relit frames.
  const nlohmann::json strict_photo = Process(session, out, "--set max_destination_photo_error=0.01");
  EXPECT_EQ(CountDecisions(strict_photo, "sh-model", "warn"), 1);
  EXPECT_EQ(strict_photo["metrics"]["misfit_reasons"],
            nlohmann::json::array({"relit frames differ from the destination photograph"}));
  for (const auto& [stage, action] : StageActions(strict_photo)) EXPECT_EQ(action, "reuse") << stage;

  // The sensor's factory response linearises the colour frames: nothing assumes sRGB.
  EXPECT_EQ(first["decisions"].dump().find("assuming the sRGB"), std::string::npos);
  EXPECT_EQ(CountDecisions(first, "radiance", "run"), 4);

  // Noise-free, static: frames 2-4 reuse the first frame's normals, with the reason.
  EXPECT_EQ(CountDecisions(first, "normals", "skip"), 3);
  for (const nlohmann::json& o : first["outputs"]) EXPECT_TRUE(fs::exists(out / o["path"].get<std::string>())) << o;
  EXPECT_TRUE(fs::exists(out / "target_light.json"));

  // Unchanged session and settings: every stage reused (compare_truth only skips the truth
  // renders of the report; it is no stage's input). How unregistered depth would be registered
  // changes nothing for depth the sensor registered.
  const nlohmann::json again = Process(session, out, "--set compare_truth=false --set depth_registration=interpolated");
  const auto actions = StageActions(again);
  EXPECT_EQ(actions.size(), 18u);  // 4 geometry + 4 fit + 4 cast shadows + 3 relight + 3 photo
  for (const auto& [stage, action] : actions) EXPECT_EQ(action, "reuse") << stage;
  // The colour frames through the sensor's factory response: one "radiance" stage per frame.
  EXPECT_EQ(CountDecisions(again, "radiance", "reuse"), 4);
  EXPECT_EQ(CountDecisions(again, "radiance", "run"), 0);

  // One knob: sh_order=1 recomputes the fits, their cast shadows, the relighting and its comparison with the truth
  // only (radiance and geometry reused).
  const nlohmann::json order1 = Process(session, out, "--set sh_order=1");
  const auto order1_actions = StageActions(order1);
  EXPECT_EQ(order1_actions.size(), 22u);  // 18 + 4 truth
  EXPECT_EQ(CountDecisions(order1, "radiance", "reuse"), 4);
  for (const auto& [stage, action] : order1_actions) {
    const bool depends = stage.rfind("fit-", 0) == 0 || stage.rfind("shadows-", 0) == 0 ||
                         stage.rfind("relight-", 0) == 0 || stage.rfind("truth-", 0) == 0 ||
                         stage.rfind("photo-", 0) == 0;
    EXPECT_EQ(action, depends ? "run" : "reuse") << stage;
  }
  for (const nlohmann::json& f : order1["metrics"]["frames"]) EXPECT_EQ(f["fit"]["order_used"], 1);
  // Order 1 follows this light less well (measured 2.08 % against 2.01 %).
  EXPECT_GT(order1["metrics"]["relit_relative_rms_mean"].get<double>(), relit);
  EXPECT_LT(order1["metrics"]["relit_relative_rms_mean"].get<double>(), baseline / 2.0);

  // The floor diagnostic: the world's normals (measured 1.53 %), recorded per frame as such, and
  // no frame's normals reused or estimated.
  const nlohmann::json floor = Process(session, out, "--set true_normals=true");
  EXPECT_LT(floor["metrics"]["relit_relative_rms_mean"].get<double>(), relit);
  EXPECT_EQ(CountDecisions(floor, "normals", "choose"), 4);
  EXPECT_EQ(CountDecisions(floor, "normals", "skip"), 0);

  // The planner drops to order 1, with the reason, when the normals do not support order 2
  // (here: a condition-number limit below the measured ~100).
  const nlohmann::json narrow = Process(session, out, "--set max_condition_number=60 --set compare_truth=false");
  EXPECT_EQ(CountDecisions(narrow, "sh-order", "choose"), 4);
  for (const nlohmann::json& d : narrow["decisions"]) {
    if (d["stage"] == "sh-order") {
      EXPECT_NE(d["reason"].get<std::string>().find("condition number"), std::string::npos);
    }
  }

  // Unknown albedo (k-means + alternating fit): the per-channel scale cancels between two
  // estimates made the same way.
  const nlohmann::json unknown = Process(session, out, "--set albedo=unknown");
  EXPECT_EQ(unknown["metrics"]["albedo"], "unknown");
  for (const auto& [stage, action] : StageActions(unknown)) {
    const bool depends = stage.rfind("fit-", 0) == 0 || stage.rfind("shadows-", 0) == 0 ||
                         stage.rfind("relight-", 0) == 0 || stage.rfind("truth-", 0) == 0 ||
                         stage.rfind("photo-", 0) == 0;
    EXPECT_EQ(action, depends ? "run" : "reuse") << stage;
  }
  EXPECT_LT(unknown["metrics"]["relit_relative_rms_mean"].get<double>(), 0.03);

  // The non-negative directional light (knob light_model, processing/nonneg_light.h) in place
  // of order-2 SH for the relighting ratio, fitted from the SH fit's samples and segment albedos
  // (measured 2026-12-07: 1.30 % against 1.53 % by SH). Only the stages after the fit run again.
  const nlohmann::json nonneg = Process(session, out, "--set light_model=nonnegative");
  EXPECT_LT(nonneg["metrics"]["relit_relative_rms_mean"].get<double>(),
            unknown["metrics"]["relit_relative_rms_mean"].get<double>());
  EXPECT_EQ(CountDecisions(nonneg, "light-model", "choose"), 1);
  EXPECT_EQ(CountDecisions(nonneg, "light-model", "warn"), 0);
  for (const auto& [stage, action] : StageActions(nonneg)) {
    const bool depends = stage.rfind("fit-", 0) == 0 || stage.rfind("shadows-", 0) == 0 ||
                         stage.rfind("relight-", 0) == 0 || stage.rfind("truth-", 0) == 0 ||
                         stage.rfind("photo-", 0) == 0;
    EXPECT_EQ(action, depends ? "run" : "reuse") << stage;
  }
  int directional_frames = 0;
  for (const nlohmann::json& f : nonneg["metrics"]["frames"]) {
    if (f.contains("relight")) directional_frames += f["relight"]["light"] == "nonnegative";
  }
  EXPECT_EQ(directional_frames, 3);
  EXPECT_TRUE(ReadJsonFile(out / "target_light.json").contains("directional"));
  const auto bad_model = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "bad").string() +
                                   " --set light_model=sg");
  EXPECT_NE(bad_model.exit_code, 0);
  EXPECT_NE(bad_model.output.find("expected sh or nonnegative"), std::string::npos) << bad_model.output;
  // With the SH light, the non-negative light's knobs change nothing: every stage is reused.
  const nlohmann::json sh_again = Process(session, out, "--set albedo=unknown --set nonneg_directions=256");
  for (const auto& [stage, action] : StageActions(sh_again)) EXPECT_EQ(action, "reuse") << stage;

  // Filtering noise-free depth anyway only rounds creases and silhouettes (measured 2.01 %).
  const nlohmann::json filtered = Process(session, out, "--set depth_noise_skip_below_m=0");
  EXPECT_EQ(CountDecisions(filtered, "denoise", "skip"), 0);
  EXPECT_GT(filtered["metrics"]["relit_relative_rms_mean"].get<double>(), relit);
  EXPECT_LT(filtered["metrics"]["relit_relative_rms_mean"].get<double>(), 0.0215);

  // Unfiltered depth gets its normals beside the box's creases from 3 x 3 boxes on each face;
  // without that knob (measured 1.89 % against 1.76 %) the geometry stages rerun.
  const nlohmann::json blended = Process(session, out, "--set refine_creases=false");
  EXPECT_GT(blended["metrics"]["relit_relative_rms_mean"].get<double>(), relit);
  int geometry_runs = 0;
  for (const auto& [stage, action] : StageActions(blended)) {
    geometry_runs += stage.rfind("geometry-", 0) == 0 && action == "run";
  }
  EXPECT_EQ(geometry_runs, 4);

  // Each pixel by its own relighting ratio, as before 2026-12-05 (measured 1.76 % against
  // 1.62 %): only the relight stages (and the relit frames' comparisons) run again.
  const nlohmann::json per_pixel = Process(session, out, "--set relight_ratio_radius=0");
  EXPECT_GT(per_pixel["metrics"]["relit_relative_rms_mean"].get<double>(), relit);
  int relight_runs = 0;
  for (const auto& [stage, action] : StageActions(per_pixel)) {
    relight_runs += stage.rfind("relight-", 0) == 0 && action == "run";
    if (stage.rfind("relight-", 0) != 0 && stage.rfind("truth-", 0) != 0 && stage.rfind("photo-", 0) != 0) {
      EXPECT_EQ(action, "reuse") << stage;
    }
  }
  EXPECT_EQ(relight_runs, 3);

  // A colour camera with lens distortion calibrated at another size than the recorded frames:
  // refused, naming what to do (undistortion itself: ADistortedColourLensIsUndistorted... below).
  std::ofstream(root / "lens.yaml") << "cameras:\n"
                                       "  - device: sim:rgbd\n"
                                       "    intrinsics: {width: 640, height: 480, horizontal_fov_deg: 60}\n"
                                       "    distortion: [-0.1, 0.01, 0, 0, 0]\n"
                                       "    position_m: [0, -2, 1]\n"
                                       "    look_at_m: [0, 0, 0.5]\n";
  const auto add =
      RunRelume("session add-scene-model " + session.string() + " --from " + (root / "lens.yaml").string());
  ASSERT_EQ(add.exit_code, 0) << add.output;
  const auto refused = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "lens").string());
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("calibrate the intrinsics at the recorded size"), std::string::npos) << refused.output;
  fs::remove_all(root);
}

// A sensor without hardware registration records depth in its own camera (320x240 at 58 deg, 2.5 cm
// from the colour camera): the pipeline registers each frame into the colour camera from the
// session's rgbd_geometry row (core/depth_registration.h), and relights as well as from the same
// scene recorded registered.
TEST(ShPipelineCliTest, UnregisteredDepthIsRegisteredFromTheRecordedGeometry) {
  const fs::path root = TempDir("unregistered");
  const fs::path registered_root = root / "registered";
  const fs::path registered = Capture(registered_root, "sim-sh-moving-light-ideal.yaml");
  const double reference =
      Process(registered, registered_root / "out")["metrics"]["relit_relative_rms_mean"].get<double>();
  const fs::path session = Capture(root, "sim-sh-moving-light-ideal-unregistered.yaml");
  const nlohmann::json interpolated = Process(session, root / "out", "--set depth_registration=interpolated");
  bool planned = false;
  for (const nlohmann::json& d : interpolated["decisions"]) {
    planned |=
        d["reason"].get<std::string>().find("recorded unregistered (320x240, the depth camera 25") != std::string::npos;
  }
  EXPECT_TRUE(planned) << interpolated["decisions"].dump(1);
  const double relit = interpolated["metrics"]["relit_relative_rms_mean"];
  const nlohmann::json nearest = Process(session, root / "out");  // the default, as hardware registers
  const double relit_nearest = nearest["metrics"]["relit_relative_rms_mean"];
  std::cout << "relit: registered by the sensor " << reference << ", here interpolated " << relit << ", nearest "
            << relit_nearest << "\n";
  // The same registration as the ideal rig's sensor does, from the stored geometry: the same result
  // (measured 1.894 % both; nearest, the default, 2.11 %).
  EXPECT_NEAR(relit, reference, 0.001);
  EXPECT_LT(relit, 0.02);
  EXPECT_LT(relit_nearest, 0.03);
  // The knob is a geometry knob: changing it recomputes the geometry stages.
  int geometry_runs = 0;
  for (const auto& [stage, action] : StageActions(nearest)) {
    if (stage.rfind("geometry-", 0) == 0) {
      EXPECT_EQ(action, "run") << stage;
      ++geometry_runs;
    }
  }
  EXPECT_EQ(geometry_runs, 4);
  fs::remove_all(root);
}

// A copy of RGB-D session `from` whose colour frames went through a lens with distortion `d`
// (bilinear) and whose registered depth went with them (nearest: depth does not blend across
// silhouettes), with the same times, exposures, response rows and stored rig; its scene model's
// camera says `model_distortion`.
// With `back`, the frames are undistorted again before they are stored (OpenCV's own maps,
// bilinear for colour, nearest for depth): what the two resamplings cost, the method's floor.
void CopyRgbdThroughLens(const fs::path& from, const fs::path& to, const std::vector<double>& d,
                         const std::vector<double>& model_distortion, bool back = false) {
  const capture::SessionReader in(from);
  capture::SessionWriterOptions options;
  options.depth_units = capture::DepthUnits::kMetres;
  const std::unique_ptr<capture::SessionWriter> out = capture::SessionWriter::Create(to, in.info(), options);
  for (const drivers::DeviceInfo& device : in.Devices()) out->AddDevice(device);
  const PinholeIntrinsics k = testing::CopySceneModelWithDistortion(in, *out, model_distortion);
  const std::vector<capture::CalibrationRecord> rows = in.Calibrations();
  for (const capture::CalibrationRecord& r : rows) {
    if (r.kind == "response") {
      capture::CalibrationRecord copy = r;
      copy.source_frame_ids.clear();
      out->AddCalibration(copy);
    }
  }
  const std::vector<capture::FrameRecord> frames = in.Frames();
  for (const capture::FrameRecord& c : frames) {
    if (c.stream != "color") continue;
    const capture::FrameRecord* depth = nullptr;
    for (const capture::FrameRecord& f : frames) {
      if (f.stream == "depth" && f.device_id == c.device_id &&
          (depth == nullptr || std::chrono::abs(f.utc - c.utc) < std::chrono::abs(depth->utc - c.utc))) {
        depth = &f;
      }
    }
    ASSERT_NE(depth, nullptr);
    drivers::RgbdFrame frame;
    frame.device_id = c.device_id;
    frame.color = in.LoadImage(c);
    frame.color.pixels = calibration::testing::ThroughLens(frame.color.pixels, k, d);
    frame.depth_m = calibration::testing::ThroughLens(in.LoadDepth(*depth), k, d, cv::INTER_NEAREST);
    if (back) {
      const cv::Matx33d k_cv(k.fx, 0.0, k.cx - 0.5, 0.0, k.fy, k.cy - 0.5, 0.0, 0.0, 1.0);
      cv::Mat map_x, map_y, colour, depth_m;
      cv::initUndistortRectifyMap(k_cv, d, cv::noArray(), k_cv, cv::Size(k.width, k.height), CV_32FC1, map_x, map_y);
      cv::remap(frame.color.pixels, colour, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
      cv::remap(frame.depth_m, depth_m, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                cv::Scalar::all(std::numeric_limits<double>::quiet_NaN()));
      frame.color.pixels = colour;
      frame.depth_m = depth_m;
    }
    frame.color_intrinsics = frame.depth_intrinsics = k;
    frame.registered_to_color = true;
    frame.color_exposure = c.exposure;
    frame.color_timing = {c.utc, c.monotonic, c.device_timestamp, c.sequence};
    frame.depth_timing = {depth->utc, depth->monotonic, depth->device_timestamp, depth->sequence};
    out->WriteRgbdFrame(frame);
  }
  fs::copy(from / "rig", to / "rig", fs::copy_options::recursive);
}

// A colour lens with distortion in the scene model: colour is undistorted onto the model's pinhole
// camera and the depth registered to the distorted image with it. The floor: the same frames
// undistorted before they are stored. Ignored: the frames taken for pinhole ones (colour and
// depth stay aligned, so only the normals' geometry and the comparison with the truth suffer).
TEST(ShPipelineCliTest, ADistortedColourLensIsUndistortedWithItsRegisteredDepth) {
  const fs::path root = TempDir("lens");
  const fs::path pinhole = Capture(root / "pinhole-capture", "sim-sh-moving-light-ideal.yaml");
  const std::vector<double> lens{-0.18, 0.04, 0.001, -0.0015, 0.0};
  ASSERT_NO_FATAL_FAILURE(CopyRgbdThroughLens(pinhole, root / "lens", lens, lens));
  ASSERT_NO_FATAL_FAILURE(CopyRgbdThroughLens(pinhole, root / "floor", lens, {}, /*back=*/true));
  ASSERT_NO_FATAL_FAILURE(CopyRgbdThroughLens(pinhole, root / "ignored", lens, {}));
  const auto relit = [](const nlohmann::json& s) { return s["metrics"]["relit_relative_rms_mean"].get<double>(); };
  const nlohmann::json a = Process(pinhole, root / "pinhole-out");
  const nlohmann::json b = Process(root / "lens", root / "lens-out");
  const nlohmann::json f = Process(root / "floor", root / "floor-out");
  const nlohmann::json c = Process(root / "ignored", root / "ignored-out");
  std::cout << "sh relit: pinhole " << relit(a) << ", lens undistorted " << relit(b) << ", floor " << relit(f)
            << ", lens ignored " << relit(c) << "\n";
  EXPECT_NE(b["decisions"].dump().find("colour undistorted onto its pinhole camera"), std::string::npos);
  EXPECT_EQ(c["decisions"].dump().find("undistorted"), std::string::npos);
  EXPECT_LT(relit(b), relit(f) * 1.1 + 0.002);
  EXPECT_LT(relit(b), relit(c));
  fs::remove_all(root);
}

// A session recorded again through playback (`backend: playback`) carries the recorded session's
// factory response and scene model: the replay is relit exactly as the recording is, not
// through an sRGB guess in the camera frame.
TEST(ShPipelineCliTest, AReplayedSessionIsRelitAsTheRecordingIs) {
  const fs::path root = TempDir("replay");
  const fs::path recorded = Capture(root, "sim-sh-moving-light-ideal.yaml");
  const fs::path rig = root / "replay.yaml";
  std::ofstream(rig) << "name: replay\nschedule: {count: 1}\nrgbd_burst_frames: 4\ndevices:\n"
                        "  - {backend: playback, session: "
                     << recorded.string() << ", device: \"sim:rgbd\"}\n";
  const fs::path replayed = root / "replayed";
  const auto r = RunRelume("capture --rig " + rig.string() + " --out " + replayed.string() + " --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 calibration row(s) of the played devices carried over"), std::string::npos) << r.output;
  const capture::SessionReader replay(replayed);
  // Stored as recorded (float metres, not 16-bit millimetres): the same files, byte for byte.
  std::vector<std::string> sums_recorded, sums_replayed;
  for (const capture::FrameRecord& f : capture::SessionReader(recorded).Frames()) sums_recorded.push_back(f.sha256);
  for (const capture::FrameRecord& f : replay.Frames()) sums_replayed.push_back(f.sha256);
  EXPECT_EQ(sums_replayed, sums_recorded);
  int responses = 0;
  for (const capture::CalibrationRecord& row : replay.Calibrations()) {
    if (row.kind == "response") {
      ++responses;
      EXPECT_EQ(row.device_id, "playback:sim:rgbd");
      EXPECT_TRUE(row.source_frame_ids.empty());
    }
  }
  EXPECT_EQ(responses, 1);
  const std::optional<SceneModel> model = capture::LatestSceneModel(replayed);
  ASSERT_TRUE(model.has_value());
  ASSERT_EQ(model->cameras.size(), 1u);
  EXPECT_EQ(model->cameras[0].device_id, "playback:sim:rgbd");

  // A rig with a simulated world of its own that also plays the session back keeps the world's
  // scene model (the recorded one would drop its cameras): only the response is carried.
  const fs::path mixed_rig = root / "mixed.yaml";
  std::ofstream(mixed_rig) << "name: mixed\nscene: " << kSource
                           << "/tests/data/scenes/sh-moving-light.yaml\n"
                              "clock: {start: \"2026-03-20T12:00:00+01:00\", mode: event}\n"
                              "schedule: {every_minutes: 1, count: 1}\nrgbd_burst_frames: 4\ndevices:\n"
                              "  - {id: rgbd, kind: rgbd_sensor, scene_camera: rgbd}\n"
                              "  - {backend: playback, session: "
                           << recorded.string() << ", device: \"sim:rgbd\"}\n";
  const auto m =
      RunRelume("capture --rig " + mixed_rig.string() + " --out " + (root / "mixed").string() + " --no-progress");
  ASSERT_EQ(m.exit_code, 0) << m.output;
  EXPECT_NE(m.output.find("1 calibration row(s) of the played devices carried over"), std::string::npos) << m.output;
  int scene_models = 0;
  for (const capture::CalibrationRecord& row : capture::SessionReader(root / "mixed").Calibrations()) {
    scene_models += row.kind == capture::kSceneModelKind;
  }
  EXPECT_EQ(scene_models, 1);
  const std::optional<SceneModel> world_model = capture::LatestSceneModel(root / "mixed");
  ASSERT_TRUE(world_model.has_value());
  ASSERT_EQ(world_model->cameras.size(), 1u);
  EXPECT_EQ(world_model->cameras[0].device_id, "sim:rgbd");

  const nlohmann::json a = Process(recorded, root / "recorded-out", "--set compare_truth=false");
  const nlohmann::json b = Process(replayed, root / "replayed-out", "--set compare_truth=false");
  EXPECT_EQ(b["decisions"].dump().find("assuming the sRGB"), std::string::npos) << b["decisions"].dump(1);
  EXPECT_NE(b["decisions"].dump().find("pose from the scene model"), std::string::npos) << b["decisions"].dump(1);
  const auto relit_outputs = [](const nlohmann::json& summary) {
    std::vector<std::string> paths;
    for (const nlohmann::json& o : summary["outputs"]) {
      if (o["path"].get<std::string>().find("relit.exr") != std::string::npos) paths.push_back(o["path"]);
    }
    return paths;
  };
  const std::vector<std::string> relit_a = relit_outputs(a), relit_b = relit_outputs(b);
  ASSERT_EQ(relit_a.size(), 3u);
  ASSERT_EQ(relit_b.size(), relit_a.size());
  for (std::size_t i = 0; i < relit_a.size(); ++i) {
    const cv::Mat x = calibration::LoadRadianceExr((root / "recorded-out" / relit_a[i]).string()).pixels;
    const cv::Mat y = calibration::LoadRadianceExr((root / "replayed-out" / relit_b[i]).string()).pixels;
    ASSERT_EQ(x.size(), y.size());
    // NaN where not relit, in both at the same pixels: compare with NaN mapped to a sentinel.
    cv::Mat xa = x.clone(), ya = y.clone();
    cv::patchNaNs(xa, -1.0);
    cv::patchNaNs(ya, -1.0);
    EXPECT_EQ(cv::norm(xa, ya, cv::NORM_INF), 0.0) << relit_a[i] << " vs " << relit_b[i];
  }
  fs::remove_all(root);
}

TEST(ShPipelineCliTest, InterreflectionBetweenTheObjectsKeepsTheRelitErrorWithinTheGoal) {
  // The moving-light scene rendered with 3 diffuse bounces (issue 26: every relighting figure
  // also with interreflection). Measured 2026-12-03: relit 1.88 %, irradiance 3.0 % (without
  // bounces 1.89 % and 3.6 %): the floating objects send each other little light. With a floor
  // under them (docs/processing-sh.md) the floor's cast shadows, not the bounces, dominate.
  const fs::path root = TempDir("bounces");
  const fs::path session = Capture(root, "sim-sh-moving-light-bounces.yaml");
  const nlohmann::json m = Process(session, root / "out")["metrics"];
  ASSERT_EQ(m["compared_frames"], 3) << m.dump(1);
  EXPECT_LT(m["relit_relative_rms_mean"].get<double>(), 0.02);
  EXPECT_LT(m["irradiance_relative_rms_mean"].get<double>(), 0.05);
  EXPECT_LT(m["relit_relative_rms_mean"].get<double>(), m["baseline_relative_rms_mean"].get<double>() / 4.0);
  // The destination photograph, no truth needed, shows the same error (measured 1.5 / 1.7 %).
  ASSERT_EQ(m["destination_photo_frames"], 3) << m.dump(1);
  ExpectPhotographTracksTheTruth(m, 0.005);
  fs::remove_all(root);
}

TEST(ShPipelineCliTest, KinectNoiseUnderAMovingLightIsFilteredAndTheDestinationPhotographShowsTheError) {
  // The moving-light scene through Kinect-like depth noise (~1.5 mm at 1 m). Measured
  // 2026-12-08: relit 2.55 % against the truth (unknown albedo shared from the destination
  // frame; 2.91 % with each frame fitted on its own, 2.55 % with the true albedo as an oracle).
  // 2026-12-07, before the normals beside silhouettes: 3.81 %, 3.5 % against the destination
  // photograph; 4.04 % and 3.8 % with the radius-3 ratio filter (before the noisy-normals one),
  // 4.98 % before the ratio filter.
  const fs::path root = TempDir("kinect_light");
  const fs::path session = Capture(root, "sim-sh-moving-light-kinect.yaml");
  const nlohmann::json s = Process(session, root / "out");
  const nlohmann::json& m = s["metrics"];
  EXPECT_EQ(CountDecisions(s, "denoise", "run"), 1);
  // The decision also widens the relighting ratio's filter for these normals, and says so.
  for (const nlohmann::json& d : s["decisions"]) {
    if (d["stage"] == "denoise") {
      EXPECT_NE(d["reason"].get<std::string>().find("filtered over 6 px"), std::string::npos) << d;
    }
  }
  ASSERT_EQ(m["compared_frames"], 3) << m.dump(1);
  EXPECT_LT(m["relit_relative_rms_mean"].get<double>(), 0.03);
  // Not relit: 11.8 % (measured).
  EXPECT_LT(m["relit_relative_rms_mean"].get<double>(), m["baseline_relative_rms_mean"].get<double>() / 2.0);
  ASSERT_EQ(m["destination_photo_frames"], 3) << m.dump(1);
  ExpectPhotographTracksTheTruth(m, 0.01);
  EXPECT_TRUE(m["sh_fits_scene"].get<bool>()) << m.dump(1);
  // The albedo is shared: the destination (last) frame is fitted with unknown albedo, the others
  // with its segments' albedos; a static view keeps its segments pixel for pixel.
  EXPECT_EQ(CountDecisions(s, "albedo", "choose"), 2);  // unknown; shared from frame N
  const nlohmann::json& frames = m["frames"];
  ASSERT_EQ(frames.size(), 4u);
  const std::int64_t reference = frames[3]["color_frame"].get<std::int64_t>();
  EXPECT_FALSE(frames[3]["fit"].contains("albedo_from_frame"));
  EXPECT_TRUE(frames[3]["fit"].contains("segment_centres"));
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& fit = frames[i]["fit"];
    EXPECT_EQ(fit["albedo_from_frame"].get<std::int64_t>(), reference);
    EXPECT_EQ(fit["segment_albedo"], frames[3]["fit"]["segment_albedo"]);
    EXPECT_GT(fit["same_surface_pixels"].get<std::int64_t>(), 0.99 * fit["pixels_with_normal"].get<double>());
    EXPECT_LT(fit["unlabelled_pixels"].get<std::int64_t>(), 0.01 * fit["pixels_with_normal"].get<double>());
  }
  // Each frame on its own (the fits rerun, the geometry is reused): the albedo-light ambiguity
  // no longer cancels.
  const nlohmann::json own = Process(session, root / "out", "--set shared_albedo=false");
  EXPECT_EQ(CountDecisions(own, "albedo", "choose"), 1);
  EXPECT_FALSE(own["metrics"]["frames"][0]["fit"].contains("albedo_from_frame"));
  EXPECT_LT(own["metrics"]["relit_relative_rms_mean"].get<double>(), 0.042);
  for (const auto& [stage, action] : StageActions(own)) {
    if (stage.rfind("geometry-", 0) == 0) {
      EXPECT_EQ(action, "reuse") << stage;
    } else if (stage.rfind("fit-", 0) == 0) {
      EXPECT_EQ(action, "run") << stage;
    }
  }
  fs::remove_all(root);
}

TEST(ShPipelineCliTest, CastShadowsOnAFloorAreReported) {
  // The moving-light objects over a floor: the key lamp's shadows on it. The fit residual stays
  // under its limit (measured 0.13 < 0.25), so until 2026-12-03 the pipeline called SH fitting
  // while relit frames were 9.0 % off (1.9 % without the floor). Marching the depth toward the
  // fitted light finds the shadows: 27.7 % of the irradiance (RMS; the floating objects alone 0 %).
  const fs::path root = TempDir("floor");
  const fs::path session = Capture(root, "sim-sh-moving-light-floor.yaml");
  const nlohmann::json s = Process(session, root / "out");
  const nlohmann::json& m = s["metrics"];
  EXPECT_LT(m["fit_residual_median"].get<double>(), 0.25);
  EXPECT_GT(m["cast_shadows"]["removed_share_median"].get<double>(), 0.2) << m["cast_shadows"].dump(1);
  EXPECT_FALSE(m["sh_fits_scene"].get<bool>());
  EXPECT_EQ(CountDecisions(s, "sh-model", "warn"), 1);
  EXPECT_NE(s["headline"].get<std::string>().find("cast shadows"), std::string::npos) << s["headline"];
  EXPECT_EQ(m["misfit_reasons"], nlohmann::json::array({"cast shadows of the fitted light"})) << m.dump(1);
  EXPECT_GT(m["relit_relative_rms_mean"].get<double>(), 0.05);  // the error it warns of
  // The destination frame's photograph shows that error without a truth: 9.3 % (truth 9.0 %),
  // under max_destination_photo_error (10 %), so this check does not add a warning.
  ExpectPhotographTracksTheTruth(m, 0.015);
  fs::remove_all(root);
}

int CountWarningsMentioning(const nlohmann::json& summary, const std::string& words) {
  int n = 0;
  for (const nlohmann::json& d : summary["decisions"]) {
    n += d["stage"] == "sh-model" && d["action"] == "warn" &&
         d["reason"].get<std::string>().find(words) != std::string::npos;
  }
  return n;
}

TEST(ShPipelineCliTest, TheRecordedSunsCastShadowsAreReportedEvenWhenTheFitLooksGood) {
  // The demo's RGB-D view of the building scene at 08:00 and 16:00. With unknown albedo the
  // colour segments split into sunlit and shadowed parts whose albedos absorb the sun: the fit
  // is mostly ambient, its residual small (measured 9.9 %), the fitted light too diffuse to
  // march toward (cast shadows 2.8 %), and until 2026-12-04 the pipeline called SH fitting
  // while relit frames were 56 % off. Toward the sun the session recorded, the depth shadows
  // 21 % of the pixels facing it and the lit ones are 2.1x as bright (measured).
  const fs::path root = TempDir("outdoor_sun");
  const fs::path session = Capture(root, "sim-sh-outdoor-sun.yaml");
  const nlohmann::json s = Process(session, root / "out");
  const nlohmann::json& m = s["metrics"];
  const nlohmann::json& shadows = m["cast_shadows"];
  EXPECT_LT(m["fit_residual_median"].get<double>(), 0.25);  // the residual alone would not tell
  EXPECT_GT(shadows["sun_shadowed_fraction_median"].get<double>(), 0.1) << shadows.dump(1);
  EXPECT_GT(shadows["sun_shadow_contrast_median"].get<double>(), 1.5) << shadows.dump(1);
  EXPECT_FALSE(m["sh_fits_scene"].get<bool>());
  EXPECT_EQ(CountWarningsMentioning(s, "toward the sun the session recorded"), 1) << s["decisions"].dump(1);
  EXPECT_EQ(m["misfit_reasons"], nlohmann::json::array({"cast shadows of the recorded sun"})) << m.dump(1);
  // The 16:00 frames clip: the sensor's meter stops at 1/4000 s at f/2, and 79 % of their pixels
  // with a normal are lower bounds (measured). Those pixels are neither sampled nor relit, and
  // each such frame is warned of (until 2026-12-05 they were fitted and relit as values: relit
  // 56 % off against the truth, now 47 %). Only a frame relit from 08:00 shares enough unclipped
  // pixels with the destination photograph to compare (2.3 % there, the shadowed surfaces).
  EXPECT_EQ(m["clipped_frames"], 2) << m.dump(1);
  EXPECT_EQ(CountDecisions(s, "radiance", "warn"), 2) << s["decisions"].dump(1);
  for (const nlohmann::json& f : m["frames"]) {
    const double clipped = f["fit"]["clipped_pixels"].get<double>() / f["fit"]["pixels_with_normal"].get<double>();
    if (f["color_frame"].get<int>() >= 6) {
      EXPECT_GT(clipped, 0.5) << f;
    } else {
      EXPECT_LT(clipped, 0.02) << f;
    }
  }
  EXPECT_NE(s["headline"].get<std::string>().find("2 colour frame(s) clipped"), std::string::npos) << s["headline"];
  EXPECT_NE(s["headline"].get<std::string>().find("the recorded sun's shadows"), std::string::npos) << s["headline"];
  EXPECT_GT(m["relit_relative_rms_mean"].get<double>(), 0.3);  // the error it warns of
  // The same scene under an overcast sky (the sun's irradiance zero, its recorded position the
  // same): the depth shadows the same pixels from where the sun is, but the image shows no
  // shadow (measured contrast 0.82), so the sun's shadows are not blamed.
  const fs::path overcast = Capture(root / "overcast", "sim-sh-outdoor-overcast.yaml");
  const nlohmann::json o = Process(overcast, root / "overcast" / "out");
  const nlohmann::json& overcast_shadows = o["metrics"]["cast_shadows"];
  EXPECT_NEAR(overcast_shadows["sun_shadowed_fraction_median"].get<double>(),
              shadows["sun_shadowed_fraction_median"].get<double>(), 1e-9);
  EXPECT_LT(overcast_shadows["sun_shadow_contrast_median"].get<double>(), 1.2) << overcast_shadows.dump(1);
  EXPECT_EQ(CountWarningsMentioning(o, "toward the sun"), 0) << o["decisions"].dump(1);
  // Nothing clips under the overcast sky, and the destination photograph shows the relit
  // frames' error without a truth (measured 2.9 %, truth 2.4 %).
  EXPECT_EQ(o["metrics"]["clipped_frames"], 0) << o["metrics"].dump(1);
  ExpectPhotographTracksTheTruth(o["metrics"], 0.01);
  EXPECT_LT(o["metrics"]["destination_photo_relative_rms_median"].get<double>(), 0.04);
  fs::remove_all(root);
}

TEST(ShPipelineCliTest, MovingObjectWithSensorNoiseRelitToAnShFile) {
  const fs::path root = TempDir("moving_object");
  const fs::path session = Capture(root, "sim-sh-moving-object-kinect.yaml");
  const std::string light = kSource + "/tests/data/lights/sh-left-above.json";
  const nlohmann::json s = Process(session, root / "out", "--target-light " + light);
  const nlohmann::json& m = s["metrics"];
  ASSERT_EQ(m["compared_frames"], 4) << m.dump(1);
  // Truth: the true albedo under the given SH light at the true normals.
  EXPECT_EQ(m["frames"][0]["truth_under_destination"], "true albedo x E_dst(true normal) / pi");
  // The method (albedo unknown: k-means segments + alternating fit) against an absolute light:
  // measured 27.7 % (Kinect noise); with the world's albedo as an oracle (albedo=truth, the floor
  // with known reflectance) 11.5 %. Until 2026-12-03 the default silently used the oracle.
  // 2026-12-08: 25.9 %, the oracle 5.76 %: the gap is the absolute scale, which unknown albedo
  // cannot know (the largest segment is taken as 0.5 grey; the big sphere is 0.75 / 0.55 / 0.45).
  EXPECT_EQ(m["albedo"], "unknown");
  // The first frame is the albedo's reference (the destination is a file); the object moves,
  // so the other frames label part of it by chromaticity.
  const std::int64_t first = m["frames"][0]["color_frame"].get<std::int64_t>();
  for (std::size_t i = 1; i < m["frames"].size(); ++i) {
    const nlohmann::json& fit = m["frames"][i]["fit"];
    EXPECT_EQ(fit["albedo_from_frame"].get<std::int64_t>(), first);
    EXPECT_GT(fit["chromaticity_labelled_pixels"].get<std::int64_t>(), 0);
    EXPECT_LT(fit["unlabelled_pixels"].get<std::int64_t>(), 0.01 * fit["pixels_with_normal"].get<double>());
  }
  EXPECT_LT(m["relit_relative_rms_mean"].get<double>(), 0.31);
  const nlohmann::json oracle = Process(session, root / "oracle", "--target-light " + light + " --set albedo=truth");
  EXPECT_EQ(oracle["metrics"]["albedo"], "truth");
  EXPECT_EQ(CountDecisions(oracle, "albedo", "warn"), 1);
  EXPECT_LT(oracle["metrics"]["relit_relative_rms_mean"].get<double>(), 0.15);
  EXPECT_LT(oracle["metrics"]["relit_relative_rms_mean"].get<double>(), m["relit_relative_rms_mean"].get<double>());
  EXPECT_GT(m["baseline_relative_rms_mean"].get<double>(), 0.8);
  EXPECT_LT(m["irradiance_relative_rms_mean"].get<double>(), 0.08);
  // The user knows one surface's albedo (the big sphere, at the image centre of the first
  // frame): light and albedos become absolute and the relit frames meet the oracle's error.
  // Without it the pipeline says so (the scale of an absolute destination is unknown).
  EXPECT_EQ(CountDecisions(s, "albedo", "warn"), 1);
  const std::string reference = "--set reference_pixel=160,120 --set \"reference_albedo=0.75, 0.55, 0.45\"";
  const nlohmann::json known = Process(session, root / "out", "--target-light " + light + " " + reference);
  EXPECT_EQ(CountDecisions(known, "albedo", "warn"), 0);
  EXPECT_LT(known["metrics"]["relit_relative_rms_mean"].get<double>(),
            oracle["metrics"]["relit_relative_rms_mean"].get<double>() + 0.02);
  EXPECT_NE(known["metrics"]["frames"][0]["fit"]["albedo"].get<std::string>().find("reference_albedo at pixel 160,120"),
            std::string::npos);
  for (const char* bad :
       {"--set reference_pixel=160,120", "--set reference_pixel=1,2,3 --set reference_albedo=0.5,0.5,0.5",
        "--set reference_pixel=160,120 --set reference_albedo=0.5,1.5,0.5",
        "--set reference_pixel=2,2 --set reference_albedo=0.5,0.5,0.5"}) {
    const auto r = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "bad").string() +
                             " --target-light " + light + " " + bad);
    ExpectUserError(r, "reference_");
  }
  // Kinect-like depth noise (measured ~1.5 mm at 1 m) is filtered.
  EXPECT_EQ(CountDecisions(s, "denoise", "run"), 1);
  // The object moves 1 cm per frame: its depth changes, so normals are recomputed every frame.
  EXPECT_EQ(CountDecisions(s, "normals", "run"), 3);
  EXPECT_EQ(CountDecisions(s, "normals", "skip"), 0);

  // An environment map (lat-long EXR, +z up, column 0 east): a dim sky with a bright patch
  // high in the west. Truth: the true albedo x the map integrated at the true normal / pi, so
  // the error includes the SH-9 projection of the map. Only the relighting stages re-run.
  RadianceImage map = MakeRadianceImage(64, 32);
  for (int v = 0; v < 32; ++v) {
    for (int u = 0; u < 64; ++u) {
      const bool patch = v >= 6 && v < 12 && u >= 28 && u < 36;
      const float sky = v < 16 ? 0.03f : 0.0f;
      map.pixels.at<cv::Vec3f>(v, u) =
          cv::Vec3f(sky, sky, 1.1f * sky) + (patch ? cv::Vec3f(0.6f, 0.55f, 0.5f) : cv::Vec3f());
    }
  }
  calibration::SaveRadianceExr(map, (root / "env.exr").string());
  const nlohmann::json env = Process(session, root / "out", "--target-light " + (root / "env.exr").string());
  for (const auto& [stage, action] : StageActions(env)) {
    // A new destination: every frame is relit and compared with the truth again.
    const bool depends =
        stage.rfind("relight-", 0) == 0 || stage.rfind("truth-", 0) == 0 || stage.rfind("photo-", 0) == 0;
    EXPECT_EQ(action, depends ? "run" : "reuse") << stage;
  }
  ASSERT_EQ(env["metrics"]["compared_frames"], 4) << env["metrics"].dump(1);
  EXPECT_LT(env["metrics"]["relit_relative_rms_mean"].get<double>(),
            env["metrics"]["baseline_relative_rms_mean"].get<double>() / 2.0);

  // A frame of a moving scene as the destination: no truth to compare with, and it says why.
  const nlohmann::json to_frame = Process(session, root / "frame", "--target-light rgbd:color");
  EXPECT_FALSE(to_frame["metrics"].contains("relit_relative_rms_mean"));
  EXPECT_NE(to_frame["metrics"]["frames"][1]["truth_under_destination"].get<std::string>().find("moved"),
            std::string::npos);
  // The destination photograph still shows the error where the frames share the static
  // background (the object moved off the rest): measured 5.1-5.3 %.
  ASSERT_TRUE(to_frame["metrics"].contains("destination_photo_relative_rms_median")) << to_frame["metrics"].dump(1);
  EXPECT_LT(to_frame["metrics"]["destination_photo_relative_rms_median"].get<double>(), 0.07);

  // User errors: a missing light file, a light file that is not SH, a bad knob.
  auto r = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "bad").string() +
                     " --target-light " + (root / "missing.json").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("missing.json"), std::string::npos) << r.output;
  std::ofstream(root / "not-sh.json") << R"({"coefficients": [[1, 2]]})";
  r = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "bad").string() + " --target-light " +
                (root / "not-sh.json").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("coefficients"), std::string::npos) << r.output;
  r = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "bad").string() +
                " --set albedo=maybe");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("auto, unknown or truth"), std::string::npos) << r.output;
  r = RunRelume("process " + session.string() + " --pipeline sh --out " + (root / "bad").string() +
                " --set albedo=known");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no known per-pixel albedo"), std::string::npos) << r.output;
  fs::remove_all(root);
}

}  // namespace
}  // namespace relume::pipeline
