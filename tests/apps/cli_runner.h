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
  return RunCommand(std::string(RELUME_BINARY) + " " + arguments);
}

}  // namespace relume::testing
