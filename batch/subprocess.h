// Starting other programs without a shell: the local backend's worker processes and Slurm's
// client commands. posix_spawnp (PATH lookup), arguments passed as they are (no quoting rules).
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace relume::batch {

struct ProgramResult {
  int exit_code = -1;  // -1 when it ended by a signal
  std::string output;  // standard output and standard error, interleaved
};

// Runs argv to its end and returns its output. InvalidArgumentError naming the program and what
// to do when it is not on PATH (`missing_hint`, e.g. "install Slurm's client commands").
ProgramResult RunProgram(const std::vector<std::string>& argv, const std::string& missing_hint);

// Starts argv with standard output and error appended to `log` (created) and standard input from
// /dev/null, in this process's environment with `environment` ("NAME=value") set on top; returns
// its pid. IoError naming the log when it cannot be opened.
pid_t SpawnWithLog(const std::vector<std::string>& argv, const std::filesystem::path& log,
                   const std::vector<std::string>& environment = {});

// "exit code 1", "signal 9 (Killed)" for a waitpid status.
std::string DescribeWaitStatus(int status);

}  // namespace relume::batch
