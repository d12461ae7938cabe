// Time in relume.
//
// Conventions:
//  - UtcTime is UTC as POSIX time (std::chrono::system_clock, which counts no leap seconds),
//    at nanosecond resolution. It covers 1677-09-22 to 2262-04-11; instants outside that range
//    are rejected where they are parsed. A leap second "23:59:60" is rejected with a message.
//  - MonotonicTime is the host's steady clock in nanoseconds: for ordering and drift only,
//    never converted to a calendar date.
//  - Astronomical scales are named where they are used: UT1 = UTC + dut1 (|dut1| < 0.9 s,
//    published by the IERS), TT = UT1 + delta_t. JulianDate values say their scale in the
//    variable name (jd_ut1, jde_tt).
//  - Text is ISO 8601: "YYYY-MM-DDTHH:MM[:SS[.fffffffff]]" followed by "Z" or an offset
//    "+HH:MM", "+HHMM" or "+HH". A time without a zone is an error, never read as local time.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

namespace relume {

using Nanoseconds = std::chrono::nanoseconds;
using UtcTime = std::chrono::sys_time<Nanoseconds>;
using MonotonicTime = std::chrono::time_point<std::chrono::steady_clock, Nanoseconds>;

UtcTime UtcNow();
MonotonicTime MonotonicNow();

// A proleptic Gregorian calendar date.
struct CivilDate {
  int year = 1970;
  int month = 1;  // 1..12
  int day = 1;    // 1..31
  friend bool operator==(const CivilDate&, const CivilDate&) = default;
};

// Days since 1970-01-01 for a proleptic Gregorian date, and back. Valid for any int year.
std::int64_t DaysFromCivil(const CivilDate& date);
CivilDate CivilFromDays(std::int64_t days_since_epoch);
bool IsLeapYear(int year);
int DaysInMonth(int year, int month);

// The result of parsing an ISO 8601 time: the instant, and the offset it was written with
// (kept so that output can be shown in the same local time).
struct ParsedTime {
  UtcTime utc;
  std::chrono::seconds utc_offset{0};
};

// Parses ISO 8601 as described at the top of this file. Throws InvalidArgumentError naming
// the text and what is wrong with it.
ParsedTime ParseIso8601(std::string_view text);

// Formats as "YYYY-MM-DDTHH:MM:SS[.f...]" plus "Z" (offset 0) or "+HH:MM".
std::string FormatIso8601(UtcTime time, std::chrono::seconds utc_offset = std::chrono::seconds{0},
                          int fractional_digits = 3);

// A Julian date split in two parts, as ERFA does: jd = day + fraction. The split keeps
// sub-microsecond precision that a single double near 2.4e6 would lose.
struct JulianDate {
  double day = 0.0;       // a half-integer (the JD of the preceding midnight)
  double fraction = 0.0;  // [0, 1)
  double Value() const { return day + fraction; }
};

// The Julian date of a UTC instant on the UTC scale (the caller adds dut1/delta_t).
JulianDate JulianDateFromUtc(UtcTime time);
// Decimal year (e.g. 2003.79), as used by delta_t models.
double DecimalYear(UtcTime time);

}  // namespace relume
