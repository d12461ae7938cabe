#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>

#include "capture/session.h"
#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;

TEST(SessionCliTest, VerifyRecoverInfo) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("session_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  {
    capture::SessionInfo info;
    info.name = "cli";
    info.site = Site::FromDegrees(37.97, 23.72, 150);
    info.created_utc = ParseIso8601("2026-06-21T06:00:00Z").utc;
    auto writer = capture::SessionWriter::Create(dir, info);
    drivers::StillFrame frame;
    frame.device_id = "sim:cam";
    frame.image.pixels = cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
    frame.timing.host_utc = info.created_utc;
    writer->WriteStillFrame(frame);
    writer->BeginBracket("sim:cam", info.created_utc, 3);  // left open, as after a crash
  }
  std::ofstream(dir / "frames" / "sim_cam" / "00000002_still.png.tmp") << "half";

  testing::CliResult verify = testing::RunRelume("session verify " + dir.string());
  EXPECT_EQ(verify.exit_code, 1) << verify.output;
  EXPECT_NE(verify.output.find("PROBLEMS: 1 frames checked"), std::string::npos) << verify.output;
  EXPECT_NE(verify.output.find("run `relume session recover`"), std::string::npos) << verify.output;

  const testing::CliResult recover = testing::RunRelume("session recover " + dir.string());
  EXPECT_EQ(recover.exit_code, 0) << recover.output;
  EXPECT_NE(recover.output.find("1 temporary files removed"), std::string::npos) << recover.output;

  verify = testing::RunRelume("session verify " + dir.string());
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_NE(verify.output.find("OK: 1 frames checked"), std::string::npos) << verify.output;

  const testing::CliResult info = testing::RunRelume("session info " + dir.string());
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("sim:cam still: 1"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("1 partial"), std::string::npos) << info.output;

  const testing::CliResult missing = testing::RunRelume("session info /nonexistent/session");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("relume: error: /nonexistent/session: no session here"), std::string::npos)
      << missing.output;
}

}  // namespace
}  // namespace relume
