#include "core/time.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace relume {
namespace {

using std::chrono::seconds;

TEST(TimeTest, CivilDaysRoundTripOverTenThousandYears) {
  for (std::int64_t days = -2'000'000; days <= 2'000'000; days += 97) {
    EXPECT_EQ(DaysFromCivil(CivilFromDays(days)), days);
  }
  EXPECT_EQ(DaysFromCivil({1970, 1, 1}), 0);
  EXPECT_EQ(DaysFromCivil({2000, 3, 1}), 11017);
  EXPECT_EQ(CivilFromDays(-1), (CivilDate{1969, 12, 31}));
}

TEST(TimeTest, ParsesZonesAndFractions) {
  const ParsedTime z = ParseIso8601("2003-10-17T19:30:30Z");
  const ParsedTime offset = ParseIso8601("2003-10-17T12:30:30-07:00");
  EXPECT_EQ(z.utc, offset.utc);
  EXPECT_EQ(offset.utc_offset, seconds(-7 * 3600));
  EXPECT_EQ(ParseIso8601("2003-10-17T12:30:30-0700").utc, z.utc);
  EXPECT_EQ(ParseIso8601("2003-10-17T12:30:30-07").utc, z.utc);
  EXPECT_EQ(ParseIso8601("2003-10-17 19:30:30z").utc, z.utc);
  EXPECT_EQ(ParseIso8601("2003-10-17T19:30Z").utc, z.utc - seconds(30));
  const ParsedTime fraction = ParseIso8601("2024-02-29T23:59:59.123456789+05:30");
  EXPECT_EQ(fraction.utc.time_since_epoch().count() % 1'000'000'000, 123456789);
  EXPECT_EQ(FormatIso8601(fraction.utc, fraction.utc_offset, 9), "2024-02-29T23:59:59.123456789+05:30");
  EXPECT_EQ(FormatIso8601(z.utc, seconds(0), 0), "2003-10-17T19:30:30Z");
}

TEST(TimeTest, RejectsWhatIsNotAnUnambiguousInstant) {
  for (const char* bad :
       {"2003-10-17T19:30:30", "2003-10-17", "2003-13-01T00:00Z", "2023-02-29T00:00Z", "2003-10-17T24:00:00Z",
        "2016-12-31T23:59:60Z", "2003-10-17T19:30:30+19:00", "2003-10-17T19:30:30.Z", "20031017T193030Z",
        "2003-10-17T19:30:30Z junk", "", "3000-01-01T00:00:00Z", "1500-01-01T00:00:00Z"}) {
    EXPECT_THROW(ParseIso8601(bad), InvalidArgumentError) << bad;
  }
  try {
    ParseIso8601("2003-10-17T19:30:30");
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("zone"), std::string::npos) << e.what();
  }
}

TEST(TimeTest, JulianDates) {
  // J2000.0 is 2000-01-01T12:00:00 (TT); as a UTC-scale JD the same formula applies.
  const JulianDate j2000 = JulianDateFromUtc(ParseIso8601("2000-01-01T12:00:00Z").utc);
  EXPECT_DOUBLE_EQ(j2000.Value(), 2451545.0);
  const JulianDate before_epoch = JulianDateFromUtc(ParseIso8601("1969-12-31T18:00:00Z").utc);
  EXPECT_DOUBLE_EQ(before_epoch.day, 2440586.5);
  EXPECT_DOUBLE_EQ(before_epoch.fraction, 0.75);
}

TEST(TimeTest, DecimalYear) {
  EXPECT_DOUBLE_EQ(DecimalYear(ParseIso8601("2024-01-01T00:00:00Z").utc), 2024.0);
  EXPECT_NEAR(DecimalYear(ParseIso8601("2023-07-02T12:00:00Z").utc), 2023.5, 1e-9);
}

}  // namespace
}  // namespace relume
