// What the CLI tests share: running the relume binary (its path comes from CMake) and capturing
// its output and exit code, a fresh temporary folder per test process (core/testing/temp_files.h),
// reading a JSON file, and
// loading a page in headless Chromium.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/testing/temp_files.h"

namespace relume::testing {

struct CliResult {
  int exit_code = -1;
  std::string output;  // standard output and standard error, interleaved
};

// Runs a shell command line (standard error joined to standard output).
inline CliResult RunCommand(const std::string& command_line) {
  const std::string command = command_line + " 2>&1";
  CliResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

inline CliResult RunRelume(const std::string& arguments) {
  std::string command = RELUME_BINARY;  // appended, not operator+: GCC 12 -O3 warns falsely there
  command += ' ';
  command += arguments;
  return RunCommand(command);
}

// A user error: exit code 2 and "relume: error: " followed by text containing `expected`.
inline void ExpectUserError(const CliResult& result, const std::string& expected) {
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("relume: error: "), std::string::npos) << result.output;
  EXPECT_NE(result.output.find(expected), std::string::npos) << "expected '" << expected << "' in:\n" << result.output;
}

// Parses a JSON file (throws nlohmann::json::parse_error when it is not JSON).
inline nlohmann::json ReadJsonFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// The page's DOM after headless Chromium loaded it (and ran its load handler); `exit_code` is
// Chromium's (127 when it is not installed: scripts/install-deps.sh installs it).
inline CliResult LoadInChromium(const std::filesystem::path& page) {
  return RunCommand(
      "chromium --headless --no-sandbox --disable-gpu --window-size=1400,900 --virtual-time-budget=5000 "
      "--dump-dom file://" +
      std::filesystem::absolute(page).string() + " 2>/dev/null");
}

}  // namespace relume::testing
