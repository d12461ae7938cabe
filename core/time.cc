#include "core/time.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "core/error.h"

namespace relume {

UtcTime UtcNow() {
  return std::chrono::time_point_cast<Nanoseconds>(std::chrono::system_clock::now());
}

MonotonicTime MonotonicNow() {
  return std::chrono::time_point_cast<Nanoseconds>(std::chrono::steady_clock::now());
}

bool IsLeapYear(int year) {
  return (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
}

int DaysInMonth(int year, int month) {
  static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  RELUME_CHECK(month >= 1 && month <= 12);
  return month == 2 && IsLeapYear(year) ? 29 : kDays[month - 1];
}

// Counts days in 400-year eras that start on March 1st, so that the leap day is the last day
// of each shifted year and month lengths follow a simple linear rule.
std::int64_t DaysFromCivil(const CivilDate& date) {
  const std::int64_t year = date.month <= 2 ? std::int64_t{date.year} - 1 : date.year;
  const std::int64_t era = (year >= 0 ? year : year - 399) / 400;
  const std::int64_t year_of_era = year - era * 400;                                                      // [0, 399]
  const std::int64_t shifted_month = (date.month + 9) % 12;                                               // March = 0
  const std::int64_t day_of_year = (153 * shifted_month + 2) / 5 + date.day - 1;                          // [0, 365]
  const std::int64_t day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;  // [0, 146096]
  return era * 146097 + day_of_era - 719468;  // 719468 days from 0000-03-01 to 1970-01-01
}

CivilDate CivilFromDays(std::int64_t days_since_epoch) {
  const std::int64_t z = days_since_epoch + 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const std::int64_t day_of_era = z - era * 146097;
  const std::int64_t year_of_era = (day_of_era - day_of_era / 1460 + day_of_era / 36524 - day_of_era / 146096) / 365;
  const std::int64_t day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
  const std::int64_t shifted_month = (5 * day_of_year + 2) / 153;
  CivilDate date;
  date.day = static_cast<int>(day_of_year - (153 * shifted_month + 2) / 5 + 1);
  date.month = static_cast<int>(shifted_month < 10 ? shifted_month + 3 : shifted_month - 9);
  date.year = static_cast<int>(year_of_era + era * 400 + (date.month <= 2 ? 1 : 0));
  return date;
}

namespace {

class Iso8601Parser {
 public:
  explicit Iso8601Parser(std::string_view text) : text_(text) {}

  ParsedTime Parse() {
    CivilDate date;
    date.year = Digits(4, "year");
    Expect('-', "'-' after the year");
    date.month = Digits(2, "month");
    Expect('-', "'-' after the month");
    date.day = Digits(2, "day");
    if (date.month < 1 || date.month > 12) Fail("month must be 01..12");
    if (date.day < 1 || date.day > DaysInMonth(date.year, date.month)) {
      Fail("day " + std::to_string(date.day) + " does not exist in that month");
    }
    if (AtEnd()) Fail("a time of day and a zone are required (e.g. 2024-06-21T12:00:00Z)");
    if (text_[pos_] != 'T' && text_[pos_] != 't' && text_[pos_] != ' ') Fail("expected 'T' after the date");
    ++pos_;
    const int hour = Digits(2, "hour");
    Expect(':', "':' after the hour");
    const int minute = Digits(2, "minute");
    int second = 0;
    std::int64_t nanos = 0;
    if (!AtEnd() && text_[pos_] == ':') {
      ++pos_;
      second = Digits(2, "second");
      if (!AtEnd() && (text_[pos_] == '.' || text_[pos_] == ',')) {
        ++pos_;
        nanos = Fraction();
      }
    }
    if (hour > 23) Fail("hour must be 00..23");
    if (minute > 59) Fail("minute must be 00..59");
    if (second == 60) Fail("leap seconds (:60) cannot be represented in POSIX UTC; use :59.999");
    if (second > 59) Fail("second must be 00..59");
    const std::chrono::seconds offset = Zone();
    if (!AtEnd()) Fail("unexpected text after the zone");

    // Range check in int64 seconds before converting to nanoseconds (which would overflow).
    const std::int64_t seconds = DaysFromCivil(date) * 86400 + hour * 3600 + minute * 60 + second - offset.count();
    constexpr std::int64_t kMaxSeconds = std::numeric_limits<std::int64_t>::max() / 1'000'000'000 - 1;
    if (seconds > kMaxSeconds || seconds < -kMaxSeconds) {
      Fail("outside the representable range 1677-09-22 .. 2262-04-11");
    }
    ParsedTime parsed;
    parsed.utc = UtcTime(Nanoseconds(seconds * 1'000'000'000 + nanos));
    parsed.utc_offset = offset;
    return parsed;
  }

 private:
  bool AtEnd() const { return pos_ >= text_.size(); }

  [[noreturn]] void Fail(const std::string& what) const {
    throw InvalidArgumentError("invalid ISO 8601 time '" + std::string(text_) + "': " + what);
  }

  void Expect(char c, const char* what) {
    if (AtEnd() || text_[pos_] != c) Fail(std::string("expected ") + what);
    ++pos_;
  }

  int Digits(int count, const char* what) {
    int value = 0;
    for (int i = 0; i < count; ++i) {
      if (AtEnd() || !std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
        Fail(std::string("expected ") + std::to_string(count) + " digits for the " + what);
      }
      value = value * 10 + (text_[pos_++] - '0');
    }
    return value;
  }

  std::int64_t Fraction() {
    std::int64_t nanos = 0;
    int digits = 0;
    while (!AtEnd() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
      if (digits < 9) nanos = nanos * 10 + (text_[pos_] - '0');
      ++digits;
      ++pos_;
    }
    if (digits == 0) Fail("expected digits after the decimal point");
    for (int i = digits; i < 9; ++i) nanos *= 10;
    return nanos;  // digits past nanoseconds are truncated
  }

  std::chrono::seconds Zone() {
    if (AtEnd()) Fail("a zone is required: append 'Z' for UTC or an offset such as +02:00");
    const char c = text_[pos_];
    if (c == 'Z' || c == 'z') {
      ++pos_;
      return std::chrono::seconds{0};
    }
    if (c != '+' && c != '-') Fail("expected 'Z' or an offset such as +02:00");
    ++pos_;
    const int hours = Digits(2, "offset hours");
    int minutes = 0;
    if (!AtEnd()) {
      if (text_[pos_] == ':') ++pos_;
      minutes = Digits(2, "offset minutes");
    }
    if (hours > 18 || minutes > 59) Fail("offset must be within +-18:00");
    const int sign = c == '-' ? -1 : 1;
    return std::chrono::seconds{sign * (hours * 3600 + minutes * 60)};
  }

  std::string_view text_;
  std::size_t pos_ = 0;
};

}  // namespace

ParsedTime ParseIso8601(std::string_view text) {
  return Iso8601Parser(text).Parse();
}

std::string FormatIso8601(UtcTime time, std::chrono::seconds utc_offset, int fractional_digits) {
  RELUME_CHECK(fractional_digits >= 0 && fractional_digits <= 9);
  const std::int64_t total_ns = (time.time_since_epoch() + utc_offset).count();
  std::int64_t seconds = total_ns / 1'000'000'000;
  std::int64_t nanos = total_ns % 1'000'000'000;
  if (nanos < 0) {
    nanos += 1'000'000'000;
    --seconds;
  }
  std::int64_t days = seconds / 86400;
  std::int64_t second_of_day = seconds % 86400;
  if (second_of_day < 0) {
    second_of_day += 86400;
    --days;
  }
  const CivilDate date = CivilFromDays(days);
  char buffer[64];
  int n = std::snprintf(buffer, sizeof(buffer), "%04d-%02d-%02dT%02d:%02d:%02d", date.year, date.month, date.day,
                        static_cast<int>(second_of_day / 3600), static_cast<int>(second_of_day / 60 % 60),
                        static_cast<int>(second_of_day % 60));
  std::string out(buffer, static_cast<std::size_t>(n));
  if (fractional_digits > 0) {
    std::int64_t scaled = nanos;
    for (int i = fractional_digits; i < 9; ++i) scaled /= 10;  // truncate, never round up a second
    n = std::snprintf(buffer, sizeof(buffer), ".%0*lld", fractional_digits, static_cast<long long>(scaled));
    out.append(buffer, static_cast<std::size_t>(n));
  }
  if (utc_offset.count() == 0) return out + "Z";
  const std::int64_t offset_minutes = std::llabs(utc_offset.count()) / 60;
  n = std::snprintf(buffer, sizeof(buffer), "%c%02d:%02d", utc_offset.count() < 0 ? '-' : '+',
                    static_cast<int>(offset_minutes / 60), static_cast<int>(offset_minutes % 60));
  return out.append(buffer, static_cast<std::size_t>(n));
}

JulianDate JulianDateFromUtc(UtcTime time) {
  constexpr double kJulianDateOfUnixEpoch = 2440587.5;
  const std::int64_t total_ns = time.time_since_epoch().count();
  std::int64_t days = total_ns / 86'400'000'000'000LL;
  std::int64_t ns_of_day = total_ns % 86'400'000'000'000LL;
  if (ns_of_day < 0) {
    ns_of_day += 86'400'000'000'000LL;
    --days;
  }
  JulianDate jd;
  jd.day = kJulianDateOfUnixEpoch + static_cast<double>(days);
  jd.fraction = static_cast<double>(ns_of_day) / 86'400'000'000'000.0;
  return jd;
}

double DecimalYear(UtcTime time) {
  const auto days = std::chrono::floor<std::chrono::days>(time);
  const CivilDate date = CivilFromDays(days.time_since_epoch().count());
  const std::int64_t start = DaysFromCivil({date.year, 1, 1});
  const double year_length = IsLeapYear(date.year) ? 366.0 : 365.0;
  const double day_of_year = static_cast<double>(days.time_since_epoch().count() - start) +
                             std::chrono::duration<double, std::ratio<86400>>(time - days).count();
  return date.year + day_of_year / year_length;
}

}  // namespace relume
