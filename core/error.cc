#include "core/error.h"

#include <cstdio>
#include <cstdlib>

namespace relume {

namespace {
std::string ConfigMessage(const std::string& file, int line, const std::string& key, const std::string& what) {
  std::string message = file;
  if (line > 0) message.append(":").append(std::to_string(line));
  message.append(": ");
  if (!key.empty()) message.append(key).append(": ");
  return message.append(what);
}
}  // namespace

ConfigError::ConfigError(std::string file, int line, std::string key, const std::string& what)
    : Error(ConfigMessage(file, line, key, what)), file_(std::move(file)), line_(line), key_(std::move(key)) {}

IoError::IoError(std::string path, const std::string& what)
    : Error(path + ": " + what), path_(std::move(path)), reason_(what) {}

namespace internal {
void CheckFailed(const char* file, int line, const char* expression, const std::string& message) {
  std::fprintf(stderr, "relume internal error (a bug, please report it): %s:%d: check `%s` failed%s%s\n", file, line,
               expression, message.empty() ? "" : ": ", message.c_str());
  std::abort();
}
}  // namespace internal

}  // namespace relume
