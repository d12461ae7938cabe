#include "core/clock.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace relume {
namespace {

TEST(ClockTest, ManualClockMovesOnlyWhenTold) {
  const UtcTime start = ParseIso8601("2026-06-21T04:00:00Z").utc;
  ManualClock clock(start);
  EXPECT_EQ(clock.NowUtc(), start);
  clock.SleepFor(std::chrono::hours(2));
  EXPECT_EQ(clock.NowUtc(), start + std::chrono::hours(2));
  EXPECT_EQ(clock.NowMonotonic().time_since_epoch(), std::chrono::hours(2));
}

TEST(ClockTest, SimulatedClockRunsFaster) {
  const UtcTime start = ParseIso8601("2026-06-21T04:00:00Z").utc;
  SimulatedClock clock(start, 3600.0);       // an hour per second
  clock.SleepFor(std::chrono::minutes(36));  // 0.6 s of real time
  const auto elapsed = clock.NowUtc() - start;
  EXPECT_GE(elapsed, std::chrono::minutes(36));
  EXPECT_LT(elapsed, std::chrono::minutes(36) + std::chrono::minutes(30));  // generous for loaded CI machines
  EXPECT_NE(clock.name().find("simulated x3600 from 2026-06-21T04:00:00Z"), std::string::npos);
  EXPECT_THROW(SimulatedClock(start, 0.0), InvalidArgumentError);
  EXPECT_THROW(SimulatedClock(start, NAN), InvalidArgumentError);
}

}  // namespace
}  // namespace relume
