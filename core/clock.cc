#include "core/clock.h"

#include <cmath>
#include <thread>

#include "core/error.h"

namespace relume {

UtcTime SystemClock::NowUtc() const {
  return UtcNow();
}
MonotonicTime SystemClock::NowMonotonic() const {
  return MonotonicNow();
}
void SystemClock::SleepFor(Nanoseconds duration) {
  if (duration.count() > 0) std::this_thread::sleep_for(duration);
}

SimulatedClock::SimulatedClock(UtcTime start_utc, double speedup)
    : start_utc_(start_utc), start_host_(MonotonicNow()), speedup_(speedup) {
  if (!(std::isfinite(speedup) && speedup > 0.0 && speedup <= 1e7)) {
    throw InvalidArgumentError("simulated clock: speed-up must be within (0, 1e7]");
  }
}

Nanoseconds SimulatedClock::Elapsed() const {
  const double host_ns = static_cast<double>((MonotonicNow() - start_host_).count());
  return Nanoseconds(static_cast<Nanoseconds::rep>(host_ns * speedup_));
}

UtcTime SimulatedClock::NowUtc() const {
  return start_utc_ + Elapsed();
}
MonotonicTime SimulatedClock::NowMonotonic() const {
  return MonotonicTime(Elapsed());
}

void SimulatedClock::SleepFor(Nanoseconds duration) {
  if (duration.count() <= 0) return;
  std::this_thread::sleep_for(
      Nanoseconds(static_cast<Nanoseconds::rep>(static_cast<double>(duration.count()) / speedup_)));
}

std::string SimulatedClock::name() const {
  char speed[32];
  std::snprintf(speed, sizeof(speed), "%g", speedup_);
  return std::string("simulated x") + speed + " from " + FormatIso8601(start_utc_, std::chrono::seconds{0}, 0);
}

ManualClock::ManualClock(UtcTime start_utc, std::string name) : name_(std::move(name)), start_utc_(start_utc) {}

UtcTime ManualClock::NowUtc() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return start_utc_ + elapsed_;
}

MonotonicTime ManualClock::NowMonotonic() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return MonotonicTime(elapsed_);
}

void ManualClock::Advance(Nanoseconds duration) {
  RELUME_CHECK(duration.count() >= 0);
  std::lock_guard<std::mutex> lock(mutex_);
  elapsed_ += duration;
}

}  // namespace relume
