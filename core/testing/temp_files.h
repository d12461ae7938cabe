// Files for tests: a fresh temporary folder per test process, and a file's text. Header-only,
// for unit tests of any layer and for the CLI tests (tests/apps/cli_runner.h).
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace relume::testing {

// An empty folder `relume_<suite>_<name>_<pid>` under the system's temporary folder: the pid
// keeps the cases of one suite apart when ctest runs them in parallel.
inline std::filesystem::path FreshTempDir(const std::string& suite, const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("relume_" + suite + "_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// The file's bytes as text (empty when it cannot be read).
inline std::string ReadText(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace relume::testing
