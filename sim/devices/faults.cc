#include "sim/devices/faults.h"

#include <cmath>

#include "drivers/device_error.h"
#include "sim/devices/random.h"

namespace relume::sim {

bool FaultPlan::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  for (double p : {timeout_probability, busy_probability, corrupt_probability, drop_probability}) {
    if (!(p >= 0.0 && p <= 1.0)) return fail("fault probabilities must be within [0, 1]");
  }
  if (!(reconnect_after_s >= 0.0)) return fail("reconnect_after_s must be >= 0 (or infinite)");
  if (!(std::isfinite(timeout_duration_s) && timeout_duration_s >= 0.0 && timeout_duration_s <= 3600.0))
    return fail("timeout_duration_s must be within [0, 3600]");
  for (const auto& [frame, jump] : clock_jumps_s) {
    if (frame == 0 || !std::isfinite(jump)) return fail("clock jumps need a frame >= 1 and a finite jump_s");
  }
  for (const auto* frames : {&timeout_frames, &busy_frames, &corrupt_frames, &truncate_frames, &drop_frames}) {
    if (frames->count(0)) return fail("frames are numbered from 1");
  }
  return true;
}

bool FaultPlan::empty() const {
  return disconnect_at_frame == 0 && timeout_frames.empty() && busy_frames.empty() && corrupt_frames.empty() &&
         truncate_frames.empty() && drop_frames.empty() && clock_jumps_s.empty() && timeout_probability == 0.0 &&
         busy_probability == 0.0 && corrupt_probability == 0.0 && drop_probability == 0.0;
}

namespace {

std::set<std::uint64_t> ReadFrames(const YamlFile& file, const YAML::Node& node, const std::string& key) {
  std::set<std::uint64_t> frames;
  const YAML::Node list = node[key];
  if (!list) return frames;
  if (!list.IsSequence()) file.Fail(list, key, "expected a list of frame numbers, e.g. [3, 7]");
  for (const YAML::Node& item : list) {
    long long frame = 0;
    if (!item.IsScalar() || !YAML::convert<long long>::decode(item, frame) || frame < 1)
      file.Fail(item, key, "frame numbers are integers >= 1");
    frames.insert(static_cast<std::uint64_t>(frame));
  }
  return frames;
}

double ReadProbability(const YamlFile& file, const YAML::Node& node, const std::string& key) {
  if (!node[key]) return 0.0;
  const double p = file.RequireDouble(node, key);
  if (!(p >= 0.0 && p <= 1.0)) file.Fail(node[key], key, "a probability within [0, 1]");
  return p;
}

}  // namespace

FaultPlan ParseFaultPlan(const YamlFile& file, const YAML::Node& node) {
  if (!node.IsMap()) file.Fail(node, "faults", "expected a mapping of fault settings");
  file.RejectUnknownKeys(
      node, {"seed", "disconnect_at_frame", "reconnect_after_s", "timeout_frames", "busy_frames", "corrupt_frames",
             "truncate_frames", "drop_frames", "clock_jumps", "timeout_probability", "busy_probability",
             "corrupt_probability", "drop_probability", "timeout_duration_s"});
  FaultPlan plan;
  if (node["seed"]) plan.seed = static_cast<std::uint64_t>(file.RequireDouble(node, "seed"));
  if (node["disconnect_at_frame"]) {
    const double frame = file.RequireDouble(node, "disconnect_at_frame");
    if (frame < 1 || frame != std::floor(frame))
      file.Fail(node["disconnect_at_frame"], "disconnect_at_frame", "an integer >= 1");
    plan.disconnect_at_frame = static_cast<std::uint64_t>(frame);
  }
  if (node["reconnect_after_s"]) {
    const YAML::Node value = node["reconnect_after_s"];
    if (value.IsScalar() && (value.Scalar() == "never" || value.Scalar() == ".inf")) {
      plan.reconnect_after_s = INFINITY;
    } else {
      plan.reconnect_after_s = file.RequireDouble(node, "reconnect_after_s");
    }
  }
  plan.timeout_frames = ReadFrames(file, node, "timeout_frames");
  plan.busy_frames = ReadFrames(file, node, "busy_frames");
  plan.corrupt_frames = ReadFrames(file, node, "corrupt_frames");
  plan.truncate_frames = ReadFrames(file, node, "truncate_frames");
  plan.drop_frames = ReadFrames(file, node, "drop_frames");
  if (const YAML::Node jumps = node["clock_jumps"]) {
    if (!jumps.IsSequence()) file.Fail(jumps, "clock_jumps", "expected a list of {frame, jump_s}");
    for (const YAML::Node& jump : jumps) {
      if (!jump.IsMap()) file.Fail(jump, "clock_jumps", "expected {frame: N, jump_s: seconds}");
      file.RejectUnknownKeys(jump, {"frame", "jump_s"});
      const double frame = file.RequireDouble(jump, "frame");
      if (frame < 1 || frame != std::floor(frame)) file.Fail(jump["frame"], "frame", "an integer >= 1");
      plan.clock_jumps_s[static_cast<std::uint64_t>(frame)] = file.RequireDouble(jump, "jump_s");
    }
  }
  plan.timeout_probability = ReadProbability(file, node, "timeout_probability");
  plan.busy_probability = ReadProbability(file, node, "busy_probability");
  plan.corrupt_probability = ReadProbability(file, node, "corrupt_probability");
  plan.drop_probability = ReadProbability(file, node, "drop_probability");
  if (node["timeout_duration_s"]) plan.timeout_duration_s = file.RequireDouble(node, "timeout_duration_s");
  std::string why;
  if (!plan.IsValid(&why)) file.Fail(node, "faults", why);
  return plan;
}

FrameFaults FaultsForFrame(const FaultPlan& plan, std::uint64_t frame) {
  FrameFaults faults;
  Rng rng(StreamSeed(plan.seed, frame));
  // Draw all four every frame, so adding one kind of random fault does not move the others.
  const double timeout_draw = rng.Uniform(), busy_draw = rng.Uniform(), corrupt_draw = rng.Uniform(),
               drop_draw = rng.Uniform();
  faults.disconnect = plan.disconnect_at_frame != 0 && frame == plan.disconnect_at_frame;
  faults.timeout = plan.timeout_frames.count(frame) > 0 || timeout_draw < plan.timeout_probability;
  faults.busy = plan.busy_frames.count(frame) > 0 || busy_draw < plan.busy_probability;
  faults.corrupt = plan.corrupt_frames.count(frame) > 0 || corrupt_draw < plan.corrupt_probability;
  faults.truncate = plan.truncate_frames.count(frame) > 0;
  faults.drop = plan.drop_frames.count(frame) > 0 || drop_draw < plan.drop_probability;
  const auto jump = plan.clock_jumps_s.find(frame);
  if (jump != plan.clock_jumps_s.end()) faults.clock_jump_s = jump->second;
  return faults;
}

DeviceLink::DeviceLink(FaultPlan plan, std::shared_ptr<const Clock> clock)
    : plan_(std::move(plan)), clock_(std::move(clock)) {
  RELUME_CHECK(clock_ != nullptr);
  ThrowIfInvalid(plan_, "fault plan");
}

std::pair<std::uint64_t, FrameFaults> DeviceLink::NextFrame() {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::uint64_t frame = ++frames_;
  const FrameFaults faults = FaultsForFrame(plan_, frame);
  jumps_ += std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(faults.clock_jump_s));
  return {frame, faults};
}

void DeviceLink::Unplug() {
  std::lock_guard<std::mutex> lock(mutex_);
  unplugged_ = true;
  unplugged_at_ = clock_->NowMonotonic();
  ++generation_;
}

bool DeviceLink::Present() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!unplugged_) return true;
  const double away_s = std::chrono::duration<double>(clock_->NowMonotonic() - unplugged_at_).count();
  return away_s >= plan_.reconnect_after_s;
}

std::uint64_t DeviceLink::generation() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return generation_;
}

Nanoseconds DeviceLink::clock_jumps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return jumps_;
}

bool DeviceLink::TryClaim() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (claimed_) return false;
  claimed_ = true;
  return true;
}

void DeviceLink::Release() {
  std::lock_guard<std::mutex> lock(mutex_);
  claimed_ = false;
}

bool DeviceClockOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(offset_s) && std::abs(offset_s) < 1e9 && std::isfinite(drift_ppm) && std::abs(drift_ppm) < 1e5)) {
    if (why) *why = "device clock: offset_s must be finite (|offset| < 1e9 s) and |drift_ppm| < 1e5";
    return false;
  }
  return true;
}

Nanoseconds DeviceClockOptions::DeviceTime(MonotonicTime host, Nanoseconds jumps) const {
  const double host_s = std::chrono::duration<double>(host.time_since_epoch()).count();
  const double device_s = offset_s + host_s * (1.0 + drift_ppm * 1e-6);
  return std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(device_s)) + jumps;
}

std::uint64_t Checksum(const std::vector<std::uint8_t>& bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (std::uint8_t b : bytes) {
    hash ^= b;
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

void TransferAndCheck(std::vector<std::uint8_t>& bytes, const FrameFaults& faults, std::uint64_t seed,
                      std::uint64_t frame, const std::string& device_id) {
  // What the device announces before sending.
  const std::size_t announced_length = bytes.size();
  const std::uint64_t announced_checksum = Checksum(bytes);
  Rng rng(StreamSeed(seed ^ 0x7472616e73666572ULL, frame));
  if (faults.truncate && !bytes.empty()) {
    bytes.resize(static_cast<std::size_t>(rng.Uniform() * static_cast<double>(bytes.size())));
  }
  if (faults.corrupt && !bytes.empty()) {
    // One damaged byte: FNV-1a is a bijection of its state per byte, so any single-byte
    // change always changes the checksum.
    const auto at = static_cast<std::size_t>(rng.Uniform() * static_cast<double>(bytes.size()));
    bytes[at] ^= static_cast<std::uint8_t>(1u << (rng.Next() % 8));
  }
  // What the receiving driver checks.
  if (bytes.size() != announced_length) {
    throw drivers::DeviceError(drivers::DeviceErrorKind::kCorruptFrame, device_id,
                               "frame " + std::to_string(frame) + " truncated: received " +
                                   std::to_string(bytes.size()) + " of " + std::to_string(announced_length) + " bytes");
  }
  if (Checksum(bytes) != announced_checksum) {
    throw drivers::DeviceError(drivers::DeviceErrorKind::kCorruptFrame, device_id,
                               "frame " + std::to_string(frame) + " failed its transfer checksum");
  }
}

}  // namespace relume::sim
