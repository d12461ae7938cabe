// What relume's fuzz harnesses share: a private scratch folder for readers that take a path, and
// the rule every harness enforces: a reader given bad bytes throws a relume::Error (a message
// that names the file and what is wrong) or succeeds; any other exception, a crash, a sanitizer
// report or a hang is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>

#include "core/error.h"

namespace relume::fuzz {

// A folder of this process's own under the temporary folder, made once, removed at exit.
inline const std::filesystem::path& ScratchDir() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path d =
        std::filesystem::temp_directory_path() / ("relume_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  static const struct Cleanup {
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } cleanup;
  return dir;
}

// Writes the input to ScratchDir()/name and returns the path.
inline std::filesystem::path WriteScratch(const std::string& name, std::span<const std::uint8_t> bytes) {
  const std::filesystem::path path = ScratchDir() / name;
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

// Runs `read`; a relume::Error is the expected answer to bad input, anything else escapes.
template <typename F>
void ExpectRelumeErrorsOnly(F&& read) {
  try {
    read();
  } catch (const Error&) {
  }
}

}  // namespace relume::fuzz
