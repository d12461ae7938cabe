#include "capture/schedule.h"

#include <cmath>

#include "core/error.h"
#include "core/sun/sun_position.h"

namespace relume::capture {

const char* ToString(ScheduleOptions::Kind kind) {
  switch (kind) {
    case ScheduleOptions::Kind::kInterval: return "interval";
    case ScheduleOptions::Kind::kSunElevationStep: return "sun_elevation_step";
    case ScheduleOptions::Kind::kCount: return "count";
  }
  return "unknown";
}

bool ScheduleOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (kind != Kind::kSunElevationStep && interval <= Nanoseconds{0}) return fail("interval must be positive");
  if (kind == Kind::kSunElevationStep && !(elevation_step_deg > 0.0 && elevation_step_deg <= 90.0)) {
    return fail("elevation step must be within (0, 90] degrees");
  }
  if (kind == Kind::kCount && count < 1) return fail("count must be at least 1");
  if (count < 0) return fail("count must not be negative");
  if (start && end && *end < *start) return fail("end is before start");
  return true;
}

Schedule::Schedule(const ScheduleOptions& options, const Site& site) : options_(options), site_(site) {
  ThrowIfInvalid(options, "schedule");
}

std::optional<UtcTime> Schedule::Next(UtcTime now, std::optional<UtcTime> previous, int triggers_so_far) const {
  if (options_.count > 0 && triggers_so_far >= options_.count) return std::nullopt;
  UtcTime next = now;
  if (options_.start && next < *options_.start) next = *options_.start;
  if (previous) {
    if (options_.kind == ScheduleOptions::Kind::kSunElevationStep) {
      const std::optional<UtcTime> step = NextElevationStep(std::max(next, *previous), *previous);
      if (!step) return std::nullopt;
      next = *step;
    } else {
      next = std::max(next, *previous + options_.interval);
    }
  }
  if (options_.end && next > *options_.end) return std::nullopt;
  return next;
}

// Searches forward in 5-minute steps for |elevation - elevation(previous)| >= step, then
// bisects to one second.
std::optional<UtcTime> Schedule::NextElevationStep(UtcTime from, UtcTime previous) const {
  const double reference = ComputeSunPosition(site_, previous).elevation_rad;
  const double step = DegToRad(options_.elevation_step_deg);
  auto reached = [&](UtcTime t) { return std::abs(ComputeSunPosition(site_, t).elevation_rad - reference) >= step; };
  if (reached(from)) return from;
  UtcTime low = from;
  for (UtcTime t = from + std::chrono::minutes(5); t <= from + std::chrono::hours(48); t += std::chrono::minutes(5)) {
    if (reached(t)) {
      UtcTime high = t;
      while (high - low > std::chrono::seconds(1)) {
        const UtcTime middle = low + (high - low) / 2;
        (reached(middle) ? high : low) = middle;
      }
      return high;
    }
    low = t;
  }
  return std::nullopt;
}

std::string Schedule::Describe() const {
  std::string text;
  switch (options_.kind) {
    case ScheduleOptions::Kind::kInterval:
      text =
          "every " + std::to_string(std::chrono::duration_cast<std::chrono::seconds>(options_.interval).count()) + " s";
      break;
    case ScheduleOptions::Kind::kSunElevationStep:
      text = "each " + std::to_string(options_.elevation_step_deg) + " deg of sun elevation change";
      break;
    case ScheduleOptions::Kind::kCount:
      text = std::to_string(options_.count) + " times, " +
             std::to_string(std::chrono::duration_cast<std::chrono::seconds>(options_.interval).count()) + " s apart";
      break;
  }
  if (options_.start) text += " from " + FormatIso8601(*options_.start, std::chrono::seconds{0}, 0);
  if (options_.end) text += " until " + FormatIso8601(*options_.end, std::chrono::seconds{0}, 0);
  return text;
}

}  // namespace relume::capture
