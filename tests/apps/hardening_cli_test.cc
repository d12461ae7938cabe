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

}  // namespace
}  // namespace relume
