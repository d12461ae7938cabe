// Issue "hardening": no write outside the session or the output folder, no input overwritten,
// one writer at a time. Each case through the relume binary, named after the case.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "capture/folder_lock.h"
#include "capture/session.h"
#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;
using testing::ExpectUserError;
using testing::FreshTempDir;
using testing::RunRelume;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// An 8-bit gamma-2.2 view of a horizontal radiance ramp (0.02 .. 1) exposed for `seconds`.
cv::Mat RampImage(double seconds) {
  cv::Mat image(48, 96, CV_8UC3);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const double radiance = 0.02 * std::pow(50.0, (x + 0.5 * y / image.rows) / image.cols);
      const double code = 255.0 * std::pow(std::min(1.0, radiance * seconds), 1.0 / 2.2);
      image.at<cv::Vec3b>(y, x) = cv::Vec3b::all(static_cast<std::uint8_t>(std::lround(code)));
    }
  }
  return image;
}

// A session whose one bracket (bracket:1, three exposures of the ramp) calibrates.
fs::path MakeSession(const fs::path& dir) {
  capture::SessionInfo info;
  info.name = "paths";
  info.site = Site::FromDegrees(37.97, 23.72, 150);
  info.created_utc = ParseIso8601("2026-06-21T06:00:00Z").utc;
  auto writer = capture::SessionWriter::Create(dir, info);
  drivers::DeviceInfo device;
  device.backend = "sim";
  device.id = "cam";
  device.kind = drivers::DeviceKind::kStillCamera;
  writer->AddDevice(device);
  const std::int64_t bracket = writer->BeginBracket("sim:cam", info.created_utc, 3);
  int index = 0;
  for (double seconds : {0.25, 1.0, 4.0}) {
    drivers::StillFrame frame;
    frame.device_id = "sim:cam";
    frame.image.pixels = RampImage(seconds);
    frame.exposure.exposure_time_s = seconds;
    frame.timing.host_utc = info.created_utc;
    writer->WriteStillFrame(frame, bracket, index++);
  }
  writer->EndBracket(bracket, "complete", "");
  return dir;
}

class PathsCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = FreshTempDir("paths", info->name());
    session_ = MakeSession(root_ / "session");
  }
  // `relume process SESSION --pipeline radiance --out OUT`.
  testing::CliResult ProcessInto(const fs::path& out) const {
    return RunRelume("process " + session_.string() + " --pipeline radiance --out " + out.string());
  }
  fs::path root_;
  fs::path session_;
};

// Issue case 1, the reported reproduction.
TEST_F(PathsCliTest, RecoverDoesNotFollowASymlinkUnderFrames) {
  const fs::path precious = root_ / "precious.txt";
  std::ofstream(precious) << "keep me";
  fs::create_symlink(precious, session_ / "frames" / "sim_cam" / "00000077_still.tiff");
  const auto r = RunRelume("session recover " + session_.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Contains(r.output, "frames/sim_cam/00000077_still.tiff alone")) << r.output;
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(precious)));
  EXPECT_EQ(ReadText(precious), "keep me");
  const auto verify = RunRelume("session verify " + session_.string());
  EXPECT_NE(verify.exit_code, 0) << verify.output;
  EXPECT_TRUE(Contains(verify.output, "not a regular file")) << verify.output;
}

// Issue case 2: hdr merge with --out naming an input (here through a hard link).
TEST_F(PathsCliTest, HdrMergeRefusesToOverwriteAnInput) {
  cv::imwrite((root_ / "a.png").string(), RampImage(0.25));
  cv::imwrite((root_ / "b.png").string(), RampImage(1.0));
  fs::create_hard_link(root_ / "a.png", root_ / "a.exr");
  const std::string before = ReadText(root_ / "a.png");
  const auto r = RunRelume("hdr merge " + (root_ / "a.png").string() + " " + (root_ / "b.png").string() +
                           " --exposures 0.25,1 --out " + (root_ / "a.exr").string());
  ExpectUserError(r, "relume never overwrites its inputs");
  EXPECT_EQ(ReadText(root_ / "a.png"), before);
}

// Issue case 2: calibrate response with --out naming an input.
TEST_F(PathsCliTest, CalibrateResponseRefusesToOverwriteAnInput) {
  for (int k = 0; k < 3; ++k)
    cv::imwrite((root_ / (std::to_string(k) + ".png")).string(), RampImage(0.25 * (1 << 2 * k)));
  const std::string before = ReadText(root_ / "0.png");
  const auto r = RunRelume("calibrate response " + (root_ / "0.png").string() + " " + (root_ / "1.png").string() + " " +
                           (root_ / "2.png").string() + " --exposures 0.25,1,4 --out " + (root_ / "0.png").string());
  ExpectUserError(r, "relume never overwrites its inputs");
  EXPECT_EQ(ReadText(root_ / "0.png"), before);
}

// Issue case 3: --out into a folder of the user's.
TEST_F(PathsCliTest, ProcessRefusesAnUnrelatedFolder) {
  fs::create_directories(root_ / "mine");
  std::ofstream(root_ / "mine" / "summary.txt") << "my notes";
  const auto r = ProcessInto(root_ / "mine");
  ExpectUserError(r, "holds files relume did not write (e.g. summary.txt)");
  EXPECT_EQ(ReadText(root_ / "mine" / "summary.txt"), "my notes");
  EXPECT_FALSE(fs::exists(root_ / "mine" / "stages"));
}

// Issue case 3: --out inside the session's frames/.
TEST_F(PathsCliTest, ProcessRefusesAnOutputInsideFrames) {
  const fs::path out = session_ / "frames" / "results";
  const auto r = ProcessInto(out);
  ExpectUserError(r, "lies inside the recorded data of the session");
  EXPECT_FALSE(fs::exists(out));
}

// Issue case 4: a second `relume process` into a folder another one is writing.
TEST_F(PathsCliTest, ProcessRefusesAFolderInUse) {
  const fs::path out = root_ / "out";
  fs::create_directories(out);
  const capture::FolderLock held = capture::FolderLock::Acquire(out, "process (the test)");
  const auto r = ProcessInto(out);
  ExpectUserError(r, "is in use by pid " + std::to_string(::getpid()) + " (relume process (the test))");
}

// Issue case 5: a bad --store-in stores nothing, in the source session either.
TEST_F(PathsCliTest, CalibrateStoreInANonSessionStoresNothing) {
  fs::create_directories(root_ / "not-a-session");
  const auto r = RunRelume("calibrate response --session " + session_.string() + " --frames bracket:1 --store-in " +
                           (root_ / "not-a-session").string() + " --out " + (root_ / "profile.json").string());
  ExpectUserError(r, "no session here");
  EXPECT_TRUE(capture::SessionReader(session_).Calibrations().empty());
  // Corrected, the retry stores exactly one row.
  const auto retry = RunRelume("calibrate response --session " + session_.string() + " --frames bracket:1 --out " +
                               (root_ / "profile.json").string());
  EXPECT_EQ(retry.exit_code, 0) << retry.output;
  EXPECT_EQ(capture::SessionReader(session_).Calibrations().size(), 1u);
}

// Issue case 5: `session info` / `verify` on a 0-byte database write nothing into it.
TEST_F(PathsCliTest, InfoOnAnEmptyDatabaseWritesNothing) {
  const fs::path dir = root_ / "empty";
  fs::create_directories(dir);
  std::ofstream(dir / capture::kSessionDatabaseName).flush();
  for (const char* command : {"session info ", "session verify "}) {
    const auto r = RunRelume(command + dir.string());
    ExpectUserError(r, "is not a relume session database");
    EXPECT_EQ(fs::file_size(dir / capture::kSessionDatabaseName), 0u);
  }
}

// Issue case 12: a session whose rig names a scene it no longer holds.
TEST_F(PathsCliTest, ProcessRefusesAStoredRigWhoseSceneIsMissing) {
  fs::create_directories(session_ / "rig");
  std::ofstream(session_ / "rig" / "rig.yaml") << "name: lost\nscene: ../../elsewhere/scene.yaml\n";
  const auto r = ProcessInto(root_ / "out");
  ExpectUserError(r, "rig/scene.yaml: is missing, although the session's rig names a scene");
}

// "A read-only session cannot even be verified": a session in a folder nobody may write, with
// no WAL shared-memory file (closed cleanly), is verified, described and processed into --out
// elsewhere; recover says it is read-only. As root (CI) the commands run as `nobody`, since
// permissions do not bind root.
TEST_F(PathsCliTest, AReadOnlySessionIsVerifiedInspectedAndProcessed) {
  const fs::path ro = root_ / "ro";
  fs::create_directories(ro);
  fs::copy(session_, ro / "session", fs::copy_options::recursive);
  for (const char* name : {"session.sqlite-wal", "session.sqlite-shm", ".relume.lock"})
    fs::remove(ro / "session" / name);
  fs::create_directories(root_ / "out");
  std::string as_user;
  if (::geteuid() == 0) {
    if (testing::RunCommand("runuser -u nobody -- true").exit_code != 0) GTEST_SKIP() << "runuser -u nobody fails";
    as_user = "runuser -u nobody -- ";
    ASSERT_EQ(testing::RunCommand("chown nobody " + (root_ / "out").string()).exit_code, 0);
  }
  ASSERT_EQ(testing::RunCommand("chmod -R a+rX,a-w " + ro.string() + " && chmod a+rx " + root_.string()).exit_code, 0);
  const std::string relume = as_user + RELUME_BINARY + " ";
  const auto verify = testing::RunCommand(relume + "session verify " + (ro / "session").string());
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_TRUE(Contains(verify.output, "OK: 3 frames checked")) << verify.output;
  const auto info = testing::RunCommand(relume + "session info " + (ro / "session").string());
  EXPECT_EQ(info.exit_code, 0) << info.output;
  const auto process = testing::RunCommand(relume + "process " + (ro / "session").string() +
                                           " --pipeline radiance --out " + (root_ / "out" / "r").string());
  EXPECT_EQ(process.exit_code, 0) << process.output;
  EXPECT_TRUE(fs::exists(root_ / "out" / "r" / "summary.json"));
  const auto recover = testing::RunCommand(relume + "session recover " + (ro / "session").string());
  ExpectUserError(recover, "is read-only, so relume cannot write here");
  testing::RunCommand("chmod -R u+w " + ro.string());  // so the next run can remove it
}

}  // namespace
}  // namespace relume
