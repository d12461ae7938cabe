// relume's error convention, used by every layer.
//
// Three kinds of failure, three mechanisms:
//  1. Bugs (a broken invariant inside relume): RELUME_CHECK / RELUME_CHECK_MSG abort with
//     file and line. They are never used for anything a user can cause.
//  2. Errors a user can cause (bad flag, bad config value, unreadable file, full disk):
//     exceptions derived from relume::Error. The message names what is wrong and what to
//     do. ConfigError carries the file, line and key; IoError the path.
//  3. Expected outcomes of numerical work (a fit that did not converge, a rank-deficient
//     system): not errors at all. Solvers return a Summary value that says how they ended.
// Options structs validate themselves with `bool IsValid(std::string* why) const` before any
// work starts; ThrowIfInvalid() turns a false into InvalidArgumentError.
#pragma once

#include <stdexcept>
#include <string>

namespace relume {

// Base of every error a user can cause. what() is the full, user-facing message.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A value passed by the user (CLI flag, API argument, CSV cell) is out of range or malformed.
class InvalidArgumentError : public Error {
 public:
  using Error::Error;
};

// A configuration file is wrong. The message reads "FILE:LINE: KEY: what is wrong".
class ConfigError : public Error {
 public:
  ConfigError(std::string file, int line, std::string key, const std::string& what);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& key() const { return key_; }

 private:
  std::string file_;
  int line_;
  std::string key_;
};

// A file or folder could not be read or written (missing, permission, disk full).
class IoError : public Error {
 public:
  IoError(std::string path, const std::string& what);
  const std::string& path() const { return path_; }
  const std::string& reason() const { return reason_; }  // what() without the leading "path: "

 private:
  std::string path_;
  std::string reason_;
};

// Throws InvalidArgumentError("<what>: <why>") when options.IsValid(&why) is false.
template <typename Options>
void ThrowIfInvalid(const Options& options, const char* what) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgumentError(std::string(what) + ": " + why);
}

namespace internal {
[[noreturn]] void CheckFailed(const char* file, int line, const char* expression, const std::string& message);
}  // namespace internal

}  // namespace relume

// Aborts on a broken internal invariant (a bug), printing where and why.
#define RELUME_CHECK(condition)                                            \
  do {                                                                     \
    if (!(condition)) {                                                    \
      ::relume::internal::CheckFailed(__FILE__, __LINE__, #condition, ""); \
    }                                                                      \
  } while (false)

#define RELUME_CHECK_MSG(condition, message)                                      \
  do {                                                                            \
    if (!(condition)) {                                                           \
      ::relume::internal::CheckFailed(__FILE__, __LINE__, #condition, (message)); \
    }                                                                             \
  } while (false)
