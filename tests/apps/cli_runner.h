// Runs the relume binary (its path comes from CMake) and captures its output and exit code.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace relume::testing {

struct CliResult {
  int exit_code = -1;
  std::string output;  // standard output and standard error, interleaved
};

inline CliResult RunRelume(const std::string& arguments) {
  const std::string command = std::string(RELUME_BINARY) + " " + arguments + " 2>&1";
  CliResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace relume::testing
