// Clocks that devices and the capture layer read. Real rigs use SystemClock; simulated rigs a
// SimulatedClock (a start time and a speed-up, so a day of sun passes in a minute) or a
// ManualClock (tests advance it by hand; sleeping advances it at once). Every frame records
// which clock its times came from (name()).
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "core/time.h"

namespace relume {

class Clock {
 public:
  virtual ~Clock() = default;
  virtual UtcTime NowUtc() const = 0;
  virtual MonotonicTime NowMonotonic() const = 0;
  // Waits for `duration` of this clock's time.
  virtual void SleepFor(Nanoseconds duration) = 0;
  // "system", "simulated x60 from 2026-06-21T04:00:00Z", "manual".
  virtual std::string name() const = 0;
};

class SystemClock final : public Clock {
 public:
  UtcTime NowUtc() const override;
  MonotonicTime NowMonotonic() const override;
  void SleepFor(Nanoseconds duration) override;
  std::string name() const override { return "system"; }
};

// Simulated time that runs `speedup` times faster than the host's steady clock, starting at
// `start_utc` when constructed. SleepFor(d) sleeps d / speedup of real time.
class SimulatedClock final : public Clock {
 public:
  SimulatedClock(UtcTime start_utc, double speedup);
  UtcTime NowUtc() const override;
  MonotonicTime NowMonotonic() const override;
  void SleepFor(Nanoseconds duration) override;
  std::string name() const override;
  double speedup() const { return speedup_; }

 private:
  Nanoseconds Elapsed() const;
  UtcTime start_utc_;
  MonotonicTime start_host_;
  double speedup_;
};

// Time that moves only when told: Advance() or SleepFor(). Thread-safe. Simulated rigs run on
// it as an event-driven clock: time passes only while devices expose, read out or wait, so a
// bracket spans its exposures however long the simulator takes to render them.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(UtcTime start_utc, std::string name = "manual");
  UtcTime NowUtc() const override;
  MonotonicTime NowMonotonic() const override;
  void SleepFor(Nanoseconds duration) override { Advance(duration); }
  void Advance(Nanoseconds duration);
  std::string name() const override { return name_; }

 private:
  std::string name_;
  mutable std::mutex mutex_;
  UtcTime start_utc_;
  Nanoseconds elapsed_{0};
};

}  // namespace relume
