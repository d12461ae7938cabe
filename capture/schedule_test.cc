#include "capture/schedule.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/sun/sun_position.h"

namespace relume::capture {
namespace {

const Site kAthens = Site::FromDegrees(37.97153, 23.72644, 190);
UtcTime T(const char* text) {
  return ParseIso8601(text).utc;
}

TEST(ScheduleTest, IntervalBetweenTimes) {
  ScheduleOptions o;
  o.interval = std::chrono::minutes(30);
  o.start = T("2026-06-21T06:00:00Z");
  o.end = T("2026-06-21T07:00:00Z");
  const Schedule schedule(o, kAthens);
  EXPECT_EQ(schedule.Next(T("2026-06-21T05:00:00Z"), std::nullopt, 0), T("2026-06-21T06:00:00Z"));
  EXPECT_EQ(schedule.Next(T("2026-06-21T06:00:01Z"), T("2026-06-21T06:00:00Z"), 1), T("2026-06-21T06:30:00Z"));
  // A late trigger (capture took long) moves to now, never into the past.
  EXPECT_EQ(schedule.Next(T("2026-06-21T06:45:00Z"), T("2026-06-21T06:00:00Z"), 1), T("2026-06-21T06:45:00Z"));
  EXPECT_EQ(schedule.Next(T("2026-06-21T06:50:00Z"), T("2026-06-21T06:30:00Z"), 2), o.end);  // end is inclusive
  EXPECT_FALSE(schedule.Next(T("2026-06-21T07:00:01Z"), T("2026-06-21T07:00:00Z"), 3));
}

TEST(ScheduleTest, FixedCount) {
  ScheduleOptions o;
  o.kind = ScheduleOptions::Kind::kCount;
  o.count = 3;
  o.interval = std::chrono::hours(1);
  const Schedule schedule(o, kAthens);
  EXPECT_TRUE(schedule.Next(T("2026-06-21T08:00:00Z"), T("2026-06-21T07:00:00Z"), 2));
  EXPECT_FALSE(schedule.Next(T("2026-06-21T09:00:00Z"), T("2026-06-21T08:00:00Z"), 3));
}

TEST(ScheduleTest, SunElevationSteps) {
  ScheduleOptions o;
  o.kind = ScheduleOptions::Kind::kSunElevationStep;
  o.elevation_step_deg = 5.0;
  const Schedule schedule(o, kAthens);
  const UtcTime first = T("2026-06-21T05:00:00Z");  // morning: the sun climbs ~12 deg/hour
  const std::optional<UtcTime> next = schedule.Next(first, first, 1);
  ASSERT_TRUE(next);
  const double change =
      RadToDeg(ComputeSunPosition(kAthens, *next).elevation_rad - ComputeSunPosition(kAthens, first).elevation_rad);
  EXPECT_NEAR(change, 5.0, 0.01);
  EXPECT_GT(*next - first, std::chrono::minutes(15));
  EXPECT_LT(*next - first, std::chrono::minutes(45));
  // Near the pole in midsummer the sun's elevation barely changes: the schedule ends, it does
  // not spin.
  o.elevation_step_deg = 30.0;
  const Schedule polar(o, Site::FromDegrees(89.9, 0, 0));
  EXPECT_FALSE(polar.Next(first, first, 1));
}

TEST(ScheduleTest, RejectsBadOptions) {
  ScheduleOptions o;
  o.interval = std::chrono::seconds(0);
  EXPECT_THROW(Schedule(o, kAthens), InvalidArgumentError);
  o = {};
  o.start = T("2026-06-21T08:00:00Z");
  o.end = T("2026-06-21T07:00:00Z");
  EXPECT_THROW(Schedule(o, kAthens), InvalidArgumentError);
  o = {};
  o.kind = ScheduleOptions::Kind::kSunElevationStep;
  o.elevation_step_deg = 0;
  EXPECT_THROW(Schedule(o, kAthens), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::capture
