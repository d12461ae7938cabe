#include "core/input_file.h"

#include <algorithm>
#include <cctype>
#include <sstream>
#include <system_error>

#include "core/error.h"

namespace relume {

std::ifstream OpenInputFile(const std::filesystem::path& path, std::ios::openmode mode) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (status.type() == std::filesystem::file_type::not_found) {
    throw IoError(path.string(), "cannot open the file for reading: it does not exist");
  }
  if (status.type() == std::filesystem::file_type::directory) {
    throw IoError(path.string(), "is a directory, not a file");
  }
  std::ifstream stream(path, mode | std::ios::in);
  if (!stream) throw IoError(path.string(), "cannot open the file for reading (permissions?)");
  return stream;
}

std::string ReadInputFile(const std::filesystem::path& path) {
  std::ifstream stream = OpenInputFile(path, std::ios::binary);
  std::ostringstream text;
  text << stream.rdbuf();
  if (stream.bad()) throw IoError(path.string(), "read error");
  return text.str();
}

std::vector<std::uint8_t> ReadInputBytes(const std::filesystem::path& path) {
  const std::string text = ReadInputFile(path);
  return {text.begin(), text.end()};
}

std::string FileFormatOf(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (!ext.empty()) ext.erase(0, 1);
  if (ext == "jpg") return "jpeg";
  if (ext == "tif") return "tiff";
  return ext;
}

}  // namespace relume
