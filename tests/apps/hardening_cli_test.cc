// Hostile and unlucky input through the relume binary (issue 25): every case ends in a clear
// "relume: error: ..." and exit code 2, or in a correct result; none reaches std::terminate.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "apps/relume/process/sh_pipeline.h"
#include "capture/session.h"
#include "core/error.h"
#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;
using testing::CliResult;
using testing::FreshTempDir;
using testing::RunRelume;

const std::string kSource = RELUME_SOURCE_DIR;

// A user error: exit code 2 and "relume: error: " followed by text containing `expected`.
void ExpectUserError(const CliResult& result, const std::string& expected) {
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("relume: error: "), std::string::npos) << result.output;
  EXPECT_NE(result.output.find(expected), std::string::npos) << "expected '" << expected << "' in:\n" << result.output;
}

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

}  // namespace
}  // namespace relume
