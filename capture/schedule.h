// When a rig captures: every N minutes between two times, each time the sun's elevation has
// changed by X degrees, or a fixed number of times N minutes apart.
#pragma once

#include <chrono>
#include <optional>
#include <string>

#include "core/site.h"
#include "core/time.h"

namespace relume::capture {

struct ScheduleOptions {
  enum class Kind { kInterval, kSunElevationStep, kCount };
  Kind kind = Kind::kInterval;
  Nanoseconds interval = std::chrono::minutes(30);  // kInterval and kCount
  std::optional<UtcTime> start;                     // no trigger before (default: the first call's now)
  std::optional<UtcTime> end;                       // no trigger after
  double elevation_step_deg = 5.0;                  // kSunElevationStep
  int count = 0;                                    // kCount: how many; for the other kinds a cap when > 0 (0 = none)
  bool IsValid(std::string* why) const;
};
const char* ToString(ScheduleOptions::Kind kind);

class Schedule {
 public:
  Schedule(const ScheduleOptions& options, const Site& site);

  // The next trigger at or after `now`, given the previous trigger; nothing when the schedule
  // is over (end passed, count reached, or the sun does not move enough within 48 h).
  std::optional<UtcTime> Next(UtcTime now, std::optional<UtcTime> previous, int triggers_so_far) const;
  const ScheduleOptions& options() const { return options_; }
  std::string Describe() const;

 private:
  std::optional<UtcTime> NextElevationStep(UtcTime now, UtcTime previous) const;
  ScheduleOptions options_;
  Site site_;
};

}  // namespace relume::capture
