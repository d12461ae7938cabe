// Frame counters and device clocks of streaming cameras, independent of any library.
//
// Conventions:
//  - Device timestamps are nanoseconds of the camera's own clock (arbitrary epoch, its own
//    rate). Host timestamps are UtcTime (system clock). A DeviceClockMapper fits
//      host = host_ref + (1 + drift) * (device - device_ref) + offset
//    over a sliding window of (device, host) pairs and maps device times to host time.
//  - The host time Aravis attaches to a GigE Vision buffer (arv_buffer_get_system_timestamp)
//    is taken when the leader packet arrives (Aravis issue #1088), i.e. after exposure and
//    readout, with one-sided network and scheduling jitter. The mapper therefore uses the
//    lower envelope of the residuals as its offset (the least-delayed frames), so a mapped
//    time means "host clock when the least-delayed frame's leader would have arrived"; the
//    fixed latency (exposure + readout + transfer) is not removed and is reported.
//  - GigE Vision 1.x frame ids (block ids) are 16 bits and skip 0: 65535 is followed by 1.
//    FrameIdUnwrapper turns them into a 64-bit sequence that never goes backwards and counts
//    the ids that never arrived.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "core/time.h"

namespace relume::drivers::aravis {

struct FrameIdUnwrapperOptions {
  int counter_bits = 16;        // width of the device's frame counter (16 for GEV 1.x, 64 for USB3 Vision)
  bool zero_is_invalid = true;  // GigE Vision skips id 0 when the counter wraps
  bool IsValid(std::string* why) const;
};

struct UnwrappedFrameId {
  std::uint64_t sequence = 0;  // 64-bit, strictly increasing
  std::uint64_t lost = 0;      // ids skipped since the previous frame (dropped frames)
  bool wrapped = false;        // the device counter wrapped between the previous frame and this one
  bool restarted = false;      // the id went backwards by more than half the range: counter reset
};

class FrameIdUnwrapper {
 public:
  explicit FrameIdUnwrapper(FrameIdUnwrapperOptions options = {});
  // Feeds the device's raw id of the next frame. A repeated id (duplicate delivery) or an id
  // 0 when zero is invalid returns std::nullopt and changes nothing.
  std::optional<UnwrappedFrameId> Next(std::uint64_t raw_id);
  std::uint64_t total_lost() const { return total_lost_; }
  std::uint64_t wraps() const { return wraps_; }

 private:
  std::uint64_t Position(std::uint64_t raw_id) const;  // index of raw_id in the cycle
  FrameIdUnwrapperOptions options_;
  std::uint64_t cycle_ = 0;  // ids per cycle (0 means 2^64)
  std::optional<std::uint64_t> last_position_;
  std::uint64_t sequence_ = 0;
  std::uint64_t total_lost_ = 0;
  std::uint64_t wraps_ = 0;
};

struct DeviceClockMapperOptions {
  int window = 256;     // most recent samples kept
  int min_samples = 8;  // fewer samples: no mapping (Summary says why)
  bool IsValid(std::string* why) const;
};

struct DeviceClockFitSummary {
  bool usable = false;  // Map() returns a time only when true
  std::string reason;   // why not usable, or "ok"
  int samples = 0;
  double drift_ppm = 0.0;         // (host ns per device ns - 1) * 1e6: negative when the device clock runs fast
  double offset_ns = 0.0;         // lower-envelope offset added to the least-squares line
  double residual_rms_ns = 0.0;   // of the least-squares line
  double residual_span_ns = 0.0;  // max - min residual: the jitter the envelope removes
  double condition = 0.0;         // spread of device times in the window (s); small = ill-conditioned drift
};

class DeviceClockMapper {
 public:
  explicit DeviceClockMapper(DeviceClockMapperOptions options = {});
  void AddSample(Nanoseconds device_time, UtcTime host_time);
  // Host time of a device instant, when the fit is usable.
  std::optional<UtcTime> Map(Nanoseconds device_time) const;
  const DeviceClockFitSummary& summary() const { return summary_; }
  void Reset();

 private:
  void Refit();
  DeviceClockMapperOptions options_;
  std::deque<std::pair<std::int64_t, std::int64_t>> samples_;  // (device ns, host ns since epoch)
  DeviceClockFitSummary summary_;
  std::int64_t device_ref_ = 0;
  std::int64_t host_ref_ = 0;
  double slope_ = 1.0;       // host ns per device ns
  double intercept_ns_ = 0;  // host - host_ref at device_ref, lower envelope applied
};

}  // namespace relume::drivers::aravis
