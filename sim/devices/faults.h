// Fault injection for simulated devices: a FaultPlan (usually from YAML) says which frames fail
// and how; DeviceLink is the shared "cable" of one device that the backend and every open
// handle of it see, so an unplugged device disappears from enumeration and comes back after
// reconnect_after_s of clock time.
//
// Frames are counted per device from 1, across reopenings: every Capture() call of a still
// camera and every frame slot of an RGB-D stream takes the next number, so a fault at frame N
// happens once, and a retry of a failed capture is frame N + 1. Random faults are drawn from a
// stream seeded by (seed, frame number): the same plan gives the same faults in every run.
//
// How each fault surfaces:
//   disconnect -> DeviceError kDisconnected; the device leaves Enumerate() and Open() throws
//                 kNotFound until reconnect_after_s of clock time has passed; old handles stay
//                 dead (kDisconnected) and must be reopened.
//   timeout    -> still: kTimeout after timeout_duration_s of clock time; RGB-D: the stream
//                 stalls for timeout_duration_s, so WaitForFrame with a shorter timeout throws
//                 kTimeout.
//   busy       -> kBusy (like gphoto2's "PTP device busy"); still cameras only.
//   corrupt    -> the frame's bytes are damaged in transfer; the checksum check throws
//                 kCorruptFrame.
//   truncate   -> the transfer ends early; the length check throws kCorruptFrame.
//   drop       -> RGB-D: the frame never arrives; the sequence number skips it.
//   clock_jump -> the device clock jumps by jump_s from that frame on (device_timestamp).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "core/clock.h"
#include "core/yaml_file.h"

namespace relume::sim {

struct FaultPlan {
  std::uint64_t seed = 0;
  std::uint64_t disconnect_at_frame = 0;  // 0: never
  double reconnect_after_s = 5.0;         // clock seconds unplugged; infinity: stays away
  std::set<std::uint64_t> timeout_frames, busy_frames, corrupt_frames, truncate_frames, drop_frames;
  std::map<std::uint64_t, double> clock_jumps_s;  // frame -> jump of the device clock, seconds
  double timeout_probability = 0.0, busy_probability = 0.0, corrupt_probability = 0.0, drop_probability = 0.0;
  double timeout_duration_s = 1.0;

  bool IsValid(std::string* why) const;
  bool empty() const;
};

// Reads a `faults:` mapping. Keys: seed, disconnect_at_frame, reconnect_after_s, timeout_frames,
// busy_frames, corrupt_frames, truncate_frames, drop_frames (lists of frame numbers),
// clock_jumps (list of {frame, jump_s}), timeout_probability, busy_probability,
// corrupt_probability, drop_probability, timeout_duration_s. ConfigError names file, line, key.
FaultPlan ParseFaultPlan(const YamlFile& file, const YAML::Node& node);

struct FrameFaults {
  bool disconnect = false, timeout = false, busy = false, corrupt = false, truncate = false, drop = false;
  double clock_jump_s = 0.0;  // a jump that happens at this frame
};

// The faults of frame `frame` (1-based) under `plan`; deterministic.
FrameFaults FaultsForFrame(const FaultPlan& plan, std::uint64_t frame);

// The connection state of one simulated device. Thread-safe.
class DeviceLink {
 public:
  DeviceLink(FaultPlan plan, std::shared_ptr<const Clock> clock);

  // Takes the next frame number and returns it with its faults; applies clock jumps.
  std::pair<std::uint64_t, FrameFaults> NextFrame();
  // Unplugs: every handle open now is dead from here on.
  void Unplug();
  // True unless unplugged and the reconnect time has not yet come (then the device is back).
  bool Present() const;
  // Changes on every unplug; a handle remembers the generation it was opened in.
  std::uint64_t generation() const;
  // Sum of the device clock jumps so far.
  Nanoseconds clock_jumps() const;
  // One handle at a time (kAccessDenied otherwise): TryClaim on open, Release on close.
  bool TryClaim();
  void Release();
  const FaultPlan& plan() const { return plan_; }

 private:
  const FaultPlan plan_;
  std::shared_ptr<const Clock> clock_;
  mutable std::mutex mutex_;
  std::uint64_t frames_ = 0;
  std::uint64_t generation_ = 0;
  bool unplugged_ = false;
  MonotonicTime unplugged_at_{};
  Nanoseconds jumps_{0};
  bool claimed_ = false;
};

// A device's own clock: offset and drift against the host's clock (the Clock it runs on).
struct DeviceClockOptions {
  double offset_s = 0.0;
  double drift_ppm = 0.0;
  bool IsValid(std::string* why) const;
  Nanoseconds DeviceTime(MonotonicTime host, Nanoseconds jumps) const;
};

// A frame's bytes as they travel from the device: damaged as the faults say, then checked the
// way a driver checks a transfer (announced length, then checksum). Throws kCorruptFrame.
void TransferAndCheck(std::vector<std::uint8_t>& bytes, const FrameFaults& faults, std::uint64_t seed,
                      std::uint64_t frame, const std::string& device_id);
// FNV-1a, 64 bit: the transfer checksum.
std::uint64_t Checksum(const std::vector<std::uint8_t>& bytes);

}  // namespace relume::sim
