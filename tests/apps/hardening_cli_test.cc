// Hostile and unlucky input through the relume binary (issue 25): every case ends in a clear
// "relume: error: ..." and exit code 2, or in a correct result; none reaches std::terminate.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "capture/session.h"
#include "core/error.h"
#include "pipeline/sh_pipeline.h"
#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;
using testing::CliResult;
using testing::ExpectUserError;
using testing::FreshTempDir;
using testing::RunRelume;

const std::string kSource = RELUME_SOURCE_DIR;

TEST(CliHardening, ParseErrorsExitTwoAndHelpExitsZero) {
  ExpectUserError(RunRelume("nosuchcommand"), "");
  EXPECT_EQ(RunRelume("sun --lat abc --lon 0").exit_code, 2);
  EXPECT_EQ(RunRelume("sun --no-such-flag").exit_code, 2);
  EXPECT_EQ(RunRelume("capture").exit_code, 2);  // --rig and --out are required
  const CliResult help = RunRelume("--help");
  EXPECT_EQ(help.exit_code, 0) << help.output;
  EXPECT_NE(help.output.find("capture"), std::string::npos) << help.output;
  EXPECT_EQ(RunRelume("sun --help").exit_code, 0);
}

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

const char* kStillCamera =
    "  - id: cam\n"
    "    kind: still_camera\n"
    "    camera: {width: 32, height: 24, horizontal_fov_deg: 70, position_m: [-6, -34, 1.7], look_at_m: [-2, 0, 5]}\n"
    "    output: raw\n";

// A bracket of three 8-bit images of a horizontal gradient, `brighten`ed by their exposure
// index (all identical when false).
std::vector<std::string> WriteGradientBracket(const fs::path& dir, bool brighten) {
  std::vector<std::string> paths;
  for (int k = 0; k < 3; ++k) {
    cv::Mat image(48, 64, CV_8UC3);
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const int code = std::min(255, (2 + 3 * x) * (brighten ? 1 << (2 * k) : 1) / 4);
        image.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<std::uint8_t>(code), static_cast<std::uint8_t>(code),
                                              static_cast<std::uint8_t>(code));
      }
    }
    paths.push_back((dir / ("frame" + std::to_string(k) + ".png")).string());
    cv::imwrite(paths.back(), image);
  }
  return paths;
}

TEST(CliHardening, DirectoryAsRigFileIsAClearError) {
  const fs::path dir = FreshTempDir("hardening", "dir_rig");
  ExpectUserError(RunRelume("capture --rig " + dir.string() + " --out " + (dir / "s").string()),
                  dir.string() + ": is a directory, not a file");
  EXPECT_FALSE(fs::exists(dir / "s"));
  ExpectUserError(RunRelume("devices --rig " + dir.string()), "is a directory, not a file");
}

TEST(CliHardening, DirectoryAsSceneSiteCornersReferenceIsAClearError) {
  const fs::path dir = FreshTempDir("hardening", "dir_inputs");
  const fs::path scene_dir = dir / "scene.yaml";
  fs::create_directories(scene_dir);
  WriteFile(dir / "rig.yaml", std::string("name: r\nscene: scene.yaml\ndevices:\n").append(kStillCamera));
  ExpectUserError(RunRelume("capture --rig " + (dir / "rig.yaml").string() + " --out " + (dir / "s").string()),
                  scene_dir.string() + ": is a directory, not a file");
  ExpectUserError(RunRelume("sun --site " + dir.string() + " --time 2026-06-21T12:00:00Z"),
                  dir.string() + ": is a directory, not a file");
  ExpectUserError(RunRelume("sim render " + dir.string() + " --camera c --out " + (dir / "out").string()),
                  dir.string() + ": is a directory, not a file");
  const std::vector<std::string> frames = WriteGradientBracket(dir, true);
  ExpectUserError(
      RunRelume("calibrate chart " + frames[0] + " --reference " + dir.string() + " --out " + (dir / "chart").string()),
      dir.string() + ": is a directory, not a file");
  ExpectUserError(RunRelume("calibrate chart " + frames[0] + " --corners-file " + dir.string() + " --out " +
                            (dir / "chart").string()),
                  dir.string() + ": is a directory, not a file");
}

// A simulated rig of one still camera looking at the outdoor building scene; `device` replaces
// the device entry, `extra` adds top-level keys.
std::string TinyRig(const std::string& device, const std::string& extra = "") {
  return "name: tiny\n"
         "scene: " +
         kSource + "/config/scenes/outdoor-building.yaml\n" +
         "clock: {start: \"2026-06-21T09:00:00+03:00\", mode: event}\n"
         "schedule: {every_minutes: 60, count: 1}\n" +
         extra + "devices:\n" + device;
}

TEST(CliHardening, RigTypeErrorsNameTheKeyAndLine) {
  const fs::path dir = FreshTempDir("hardening", "rig_types");
  const fs::path rig = dir / "rig.yaml";
  auto run = [&](const std::string& text) {
    WriteFile(rig, text);
    return RunRelume("capture --rig " + rig.string() + " --out " + (dir / "s").string());
  };
  // Line 6 is the first device entry in TinyRig.
  ExpectUserError(run(TinyRig("  - backend: {a: 1}\n")), rig.string() + ":6: backend: expected text");
  ExpectUserError(run(TinyRig("  - 42\n")), rig.string() + ":6: devices: each device is a mapping");
  ExpectUserError(run(TinyRig("  - id: cam\n    scene_camera: {a: 1}\n")),
                  rig.string() + ":7: scene_camera: expected text");
  EXPECT_FALSE(fs::exists(dir / "s"));
  WriteFile(rig, TinyRig("  - 42\n"));
  ExpectUserError(RunRelume("devices --rig " + rig.string()), rig.string() + ":6: devices: each device is a mapping");
}

TEST(CliHardening, ErrorsInsideADeviceEntryReportItsOwnLine) {
  const fs::path dir = FreshTempDir("hardening", "rig_lines");
  const fs::path rig = dir / "rig.yaml";
  // The second device's sensor (line 12) holds an unknown key.
  WriteFile(rig, TinyRig(std::string(kStillCamera) +
                         "  - id: cam2\n"
                         "    kind: still_camera\n"
                         "    camera: {width: 32, height: 24, horizontal_fov_deg: 70, position_m: [0, 0, 1], "
                         "look_at_m: [1, 0, 1]}\n"
                         "    sensor: {nosuchkey: 1}\n"));
  ExpectUserError(RunRelume("capture --rig " + rig.string() + " --out " + (dir / "s").string()),
                  rig.string() + ":13: nosuchkey: unknown key");
}

TEST(CliHardening, HugeCountsAreOutOfRangeNotNegative) {
  const fs::path dir = FreshTempDir("hardening", "counts");
  const fs::path rig = dir / "rig.yaml";
  WriteFile(rig, "name: tiny\nscene: " + kSource +
                     "/config/scenes/outdoor-building.yaml\n"
                     "schedule: {every_minutes: 60, count: 1e12}\n"
                     "devices:\n" +
                     kStillCamera);
  ExpectUserError(RunRelume("capture --rig " + rig.string() + " --out " + (dir / "s").string()),
                  "count: '1e12' is not a whole number in [0, 2147483647]");
  WriteFile(rig, TinyRig(kStillCamera, "rgbd_burst_frames: 1e12\n"));
  ExpectUserError(RunRelume("capture --rig " + rig.string() + " --out " + (dir / "s").string()),
                  "rgbd_burst_frames: '1e12' is not a whole number");
  WriteFile(rig, TinyRig(kStillCamera, "duration_minutes: 1e300\n"));
  ExpectUserError(RunRelume("capture --rig " + rig.string() + " --out " + (dir / "s").string()),
                  "duration_minutes: must be at most 100 years");
  EXPECT_FALSE(fs::exists(dir / "s"));
}

TEST(CliHardening, CaptureWithoutClockStartsAtTheSchedule) {
  const fs::path dir = FreshTempDir("hardening", "no_clock");
  // The scene's time is 18:30; the schedule ends at 10:00.
  const std::string rig = "name: tiny\nscene: " + kSource +
                          "/config/scenes/outdoor-building.yaml\n"
                          "schedule: {every_minutes: 60, start: \"2026-06-21T09:00:00+03:00\", "
                          "end: \"2026-06-21T10:00:00+03:00\"}\n"
                          "devices:\n" +
                          kStillCamera;
  WriteFile(dir / "rig.yaml", rig);
  const CliResult result =
      RunRelume("capture --no-progress --rig " + (dir / "rig.yaml").string() + " --out " + (dir / "session").string());
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("in 2 brackets"), std::string::npos) << result.output;
  // A clock that starts after the schedule's end records nothing: an error, not an empty session.
  WriteFile(dir / "late.yaml", "clock: {start: \"2026-06-21T18:30:00+03:00\"}\n" + rig);
  ExpectUserError(RunRelume("capture --rig " + (dir / "late.yaml").string() + " --out " + (dir / "late").string()),
                  "schedule.end: the schedule ends (2026-06-21T07:00:00Z) before the simulated clock starts");
  EXPECT_FALSE(fs::exists(dir / "late"));
}

TEST(CliHardening, HugeImageSizeIsRefusedBeforeAllocating) {
  const fs::path dir = FreshTempDir("hardening", "huge");
  ExpectUserError(RunRelume("sim render " + kSource + "/config/scenes/outdoor-building.yaml --camera street " +
                            "--width 2000000000 --height 1 --out " + (dir / "render").string()),
                  "2000000000x1 is more than relume's maximum of 2^28 (268 million) pixels");
  const fs::path rig = dir / "rig.yaml";
  WriteFile(rig, TinyRig("  - id: cam\n"
                         "    camera: {width: 100000, height: 100000, horizontal_fov_deg: 70, position_m: [0, 0, 1], "
                         "look_at_m: [1, 0, 1]}\n"));
  ExpectUserError(RunRelume("capture --rig " + rig.string() + " --out " + (dir / "s").string()),
                  "camera: image size 100000x100000 is more than relume's maximum");
  EXPECT_FALSE(fs::exists(dir / "s")) << "an invalid rig must leave no session behind";
}

TEST(CliHardening, SunSeriesLongerThan292YearsIsComplete) {
  // 1700 .. 2200 in steps of 365 days: 500 years, beyond int64 nanoseconds' 292.
  const CliResult result =
      RunRelume("sun --lat 37.97 --lon 23.72 --time 1700-01-01T00:00:00Z --until 2200-01-01T00:00:00Z --step 31536000");
  ASSERT_EQ(result.exit_code, 0) << result.output.substr(0, 2000);
  std::istringstream lines(result.output);
  std::string line, last;
  int rows = -1;  // the header
  while (std::getline(lines, line)) {
    ++rows;
    last = line;
  }
  EXPECT_EQ(rows, 501);  // 182621 days / 365 = 500.3: steps 0..500
  EXPECT_EQ(last.substr(0, 4), "2199") << last;
}

TEST(CliHardening, SunCsvShortRowNulAndBom) {
  const fs::path dir = FreshTempDir("hardening", "csv");
  const fs::path csv = dir / "in.csv";
  const std::string flags = "sun --lat 10 --lon 20 --csv " + csv.string();
  WriteFile(csv, "time,lat,lon\n2026-06-21T12:00:00Z,37.9,23.7\n2026-06-21T13:00:00Z,37.9\n");
  ExpectUserError(RunRelume(flags), csv.string() + ":3: the row has 2 cells, the header 3");
  WriteFile(csv, std::string("time,la\0t,lon\n2026-06-21T12:00:00Z,37.9,23.7\n", 44));
  ExpectUserError(RunRelume(flags), csv.string() + ":1: a NUL byte at column 8");
  WriteFile(csv, "\xEF\xBB\xBFtime,lat,lon\n2026-06-21T12:00:00Z,37.9,23.7\n");
  const CliResult bom = RunRelume(flags);
  EXPECT_EQ(bom.exit_code, 0) << bom.output;
  EXPECT_NE(bom.output.find("2026-06-21T12:00:00.000Z,37.900000,23.700000"), std::string::npos) << bom.output;
}

TEST(CliHardening, HdrMergeRefusesAbsurdExposuresAndIntegerOutput) {
  const fs::path dir = FreshTempDir("hardening", "hdr");
  const std::vector<std::string> frames = WriteGradientBracket(dir, true);
  const std::string files = frames[0] + " " + frames[1] + " " + frames[2];
  ExpectUserError(RunRelume("hdr merge " + files + " --exposures 1e-320,1,4 --out " + (dir / "m.exr").string()),
                  "frame0.png: exposure time 9.99989e-321 s is outside the usable range [1e-09, 100000] s");
  ExpectUserError(RunRelume("hdr merge " + files + " --exposures 0.25,1,1e308 --out " + (dir / "m.exr").string()),
                  "exposure time 1e+308 s is outside the usable range");
  ExpectUserError(RunRelume("hdr merge " + files + " --exposures 0.25,1,4 --out " + (dir / "x.png").string()),
                  "radiance is floating point; write it as .exr");
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

TEST(CliHardening, CalibrateResponseOnIdenticalImagesIsRefused) {
  const fs::path dir = FreshTempDir("hardening", "identical");
  const std::vector<std::string> frames = WriteGradientBracket(dir, false);
  ExpectUserError(RunRelume("calibrate response " + frames[0] + " " + frames[1] + " " + frames[2] +
                            " --exposures 0.25,1,4 --out " + (dir / "response").string()),
                  "the frames do not change with exposure");
}

// Records a session with `rig_text` into `dir`/session and returns its folder (fails the test
// when the capture does not exit 0).
fs::path Capture(const fs::path& dir, const std::string& rig_text) {
  WriteFile(dir / "rig.yaml", rig_text);
  const fs::path session = dir / "session";
  const CliResult result =
      RunRelume("capture --no-progress --rig " + (dir / "rig.yaml").string() + " --out " + session.string());
  EXPECT_EQ(result.exit_code, 0) << result.output;
  return session;
}

TEST(CliHardening, SessionFrameWithBadExposureIsNamed) {
  const fs::path dir = FreshTempDir("hardening", "bad_exposure");
  const fs::path session = Capture(dir, TinyRig(kStillCamera));
  const std::string db = (session / "session.sqlite").string();
  for (const char* value : {"-1", "NULL"}) {
    const CliResult update =
        testing::RunCommand("sqlite3 " + db + " \"UPDATE frames SET exposure_time_s = " + value +
                            " WHERE id = (SELECT MAX(id) FROM frames WHERE bracket_id IS NOT NULL)\"");
    ASSERT_EQ(update.exit_code, 0) << update.output;
    const CliResult result =
        RunRelume("process " + session.string() + " --pipeline radiance --out " + (dir / "out").string());
    ExpectUserError(result, std::string(value) == "NULL" ? "has no exposure time" : "has exposure time -1.000000 s");
    EXPECT_NE(result.output.find(": frame "), std::string::npos) << result.output;
  }
}

TEST(CliHardening, ExtremeLightIsRefused) {
  EXPECT_THROW(
      {
        try {
          pipeline::ShLightFromJson(nlohmann::json{{"coefficients", {{1e308, 1.0, 1.0}}}}, "light.json");
        } catch (const InvalidArgumentError& e) {
          EXPECT_NE(std::string(e.what()).find("light.json: row 0 holds"), std::string::npos) << e.what();
          throw;
        }
      },
      InvalidArgumentError);
  const fs::path dir = FreshTempDir("hardening", "irradiance");
  std::ifstream in(kSource + "/config/scenes/outdoor-building.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string scene = text.str();
  const std::size_t at = scene.find("irradiance_w_m2:");
  ASSERT_NE(at, std::string::npos);
  scene.replace(at, scene.find('\n', at) - at, "irradiance_w_m2: [1e308, 1e308, 1e308]");
  WriteFile(dir / "scene.yaml", scene);
  const CliResult result =
      RunRelume("sim render " + (dir / "scene.yaml").string() + " --camera street --out " + (dir / "r").string());
  ExpectUserError(result, "irradiance_w_m2: must be non-negative and at most 1e9 per channel");
}

TEST(CliHardening, SimRgbdSensorRecordsTheRigCameraSize) {
  const fs::path dir = FreshTempDir("hardening", "rgbd_size");
  const fs::path session = Capture(dir, TinyRig("  - id: rgbd\n"
                                                "    kind: rgbd_sensor\n"
                                                "    camera: {width: 160, height: 120, horizontal_fov_deg: 70, "
                                                "position_m: [-6, -34, 1.7], look_at_m: [-2, 0, 5]}\n",
                                                "rgbd_burst_frames: 1\n"));
  const capture::SessionReader reader(session);
  int depth_frames = 0;
  for (const capture::FrameRecord& f : reader.Frames()) {
    if (f.stream != "depth") continue;
    ++depth_frames;
    EXPECT_EQ(f.width, 160);
    EXPECT_EQ(f.height, 120);
  }
  EXPECT_EQ(depth_frames, 1);
}

TEST(CliHardening, PlaybackRigWithoutScheduleStopsWhenTheSessionEnds) {
  const fs::path dir = FreshTempDir("hardening", "playback");
  const fs::path recorded = Capture(dir, TinyRig(kStillCamera));
  WriteFile(dir / "replay.yaml",
            "name: replay\n"
            "devices:\n"
            "  - backend: playback\n"
            "    session: " +
                recorded.string() +
                "\n"
                "    device: sim:cam\n");
  const CliResult result =
      testing::RunCommand("timeout 120 " + std::string(RELUME_BINARY) + " capture --no-progress --rig " +
                          (dir / "replay.yaml").string() + " --out " + (dir / "replayed").string());
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("in 1 brackets"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("stopped: the played session has no more brackets"), std::string::npos) << result.output;
  const capture::SessionReader reader(dir / "replayed");
  int no_more = 0;
  for (const capture::EventRecord& e : reader.Events()) {
    no_more += e.type == "skip" && e.message == "the played session has no more brackets";
  }
  EXPECT_EQ(no_more, 1);
}

}  // namespace
}  // namespace relume
