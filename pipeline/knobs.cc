#include "pipeline/knobs.h"

#include <charconv>
#include <cmath>

#include "core/error.h"

namespace relume::pipeline {

namespace {

template <typename T>
bool ParseNumber(std::string_view text, T* value) {
  T parsed{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, parsed);
  if (ec != std::errc() || ptr != end || text.empty()) return false;
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(parsed)) return false;
  }
  *value = parsed;
  return true;
}

}  // namespace

bool ParseKnobValue(std::string_view text, bool* value) {
  if (text == "true" || text == "1" || text == "yes") {
    *value = true;
    return true;
  }
  if (text == "false" || text == "0" || text == "no") {
    *value = false;
    return true;
  }
  return false;
}
bool ParseKnobValue(std::string_view text, int* value) {
  return ParseNumber(text, value);
}
bool ParseKnobValue(std::string_view text, std::int64_t* value) {
  return ParseNumber(text, value);
}
bool ParseKnobValue(std::string_view text, float* value) {
  return ParseNumber(text, value);
}
bool ParseKnobValue(std::string_view text, double* value) {
  return ParseNumber(text, value);
}
bool ParseKnobValue(std::string_view text, std::string* value) {
  *value = std::string(text);
  return true;
}

const char* KnobTypeExpectation(const bool*) {
  return "true or false";
}
const char* KnobTypeExpectation(const int*) {
  return "an integer";
}
const char* KnobTypeExpectation(const std::int64_t*) {
  return "an integer";
}
const char* KnobTypeExpectation(const float*) {
  return "a finite number";
}
const char* KnobTypeExpectation(const double*) {
  return "a finite number";
}
const char* KnobTypeExpectation(const std::string*) {
  return "text";
}

namespace internal {

void ThrowBadKnobValue(std::string_view name, std::string_view text, const char* expected) {
  throw InvalidArgumentError("--set " + std::string(name) + "=" + std::string(text) + ": expected " + expected);
}

}  // namespace internal

}  // namespace relume::pipeline
