// Opening a file the user named (a flag, a rig's `scene:`, a site file) for reading, with an
// IoError that says what is wrong with the path: missing, a directory, or unreadable. Without
// this check a directory opens as an empty stream on Linux and the first read throws
// std::ios_failure ("Is a directory") from deep inside a parser.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace relume {

// Throws IoError naming `path` when it does not exist, is a directory or cannot be opened.
std::ifstream OpenInputFile(const std::filesystem::path& path, std::ios::openmode mode = std::ios::in);
// The whole file, byte for byte (errors as OpenInputFile's, and read errors).
std::string ReadInputFile(const std::filesystem::path& path);
// The same as bytes (an image file kept byte for byte).
std::vector<std::uint8_t> ReadInputBytes(const std::filesystem::path& path);

// The format name a session records for a file ("jpeg", "tiff", "png", "cr2", ...): its
// extension in lower case, without the dot, with "jpg" as "jpeg" and "tif" as "tiff".
std::string FileFormatOf(const std::filesystem::path& path);

}  // namespace relume
