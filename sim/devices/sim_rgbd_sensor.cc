#include "sim/devices/sim_rgbd_sensor.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/devices/random.h"

namespace relume::sim {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::RgbdFrame;
using drivers::RgbdStreamConfig;

namespace {

Nanoseconds Seconds(double s) {
  return std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(s));
}

bool SameConfig(const RgbdStreamConfig& a, const RgbdStreamConfig& b) {
  return a.depth_width == b.depth_width && a.depth_height == b.depth_height && a.color_width == b.color_width &&
         a.color_height == b.color_height && std::abs(a.fps - b.fps) < 1e-6 &&
         a.register_depth_to_color == b.register_depth_to_color && a.sync_depth_and_color == b.sync_depth_and_color;
}

}  // namespace

SimRgbdOptions::SimRgbdOptions() {
  color_model.response = ResponseCurve::Gamma(2.2);
  color_model.raw_bits = 8;
  color_model.full_well_e = 10000.0;
  for (auto [w, h] : {std::pair{640, 480}, std::pair{320, 240}}) {
    for (bool registered : {true, false}) {
      for (bool sync : {true, false}) {
        RgbdStreamConfig config;
        config.depth_width = config.color_width = w;
        config.depth_height = config.color_height = h;
        config.fps = 30.0;
        config.register_depth_to_color = registered;
        config.sync_depth_and_color = sync;
        configs.push_back(config);
      }
    }
  }
}

bool SimRgbdOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  std::string reason;
  if (!depth.IsValid(&reason)) return fail("depth: " + reason);
  if (!color_model.IsValid(&reason)) return fail("colour camera model: " + reason);
  if (!color_exposure.IsValid(&reason)) return fail("colour exposure: " + reason);
  if (color_auto_exposure && !color_metering.IsValid(&reason)) return fail("colour metering: " + reason);
  if (!device_clock.IsValid(&reason)) return fail(reason);
  if (!(color_horizontal_fov_rad > 0.01 && color_horizontal_fov_rad < 3.0))
    return fail("color_horizontal_fov_rad must be within (0.01, 3)");
  if (configs.empty()) return fail("at least one stream config is needed");
  for (const RgbdStreamConfig& config : configs) {
    if (!config.IsValid(&reason)) return fail("stream config: " + reason);
  }
  if (!(frame_jitter_s >= 0.0 && transfer_latency_s >= 0.0 && unsynced_color_delay_s >= 0.0))
    return fail("jitter, latency and colour delay must be >= 0");
  if (queue_capacity < 1 || queue_capacity > 1000) return fail("queue_capacity must be within 1..1000");
  return true;
}

PinholeIntrinsics ScaleIntrinsics(const PinholeIntrinsics& k, int width, int height) {
  PinholeIntrinsics scaled = k;
  const double sx = static_cast<double>(width) / k.width, sy = static_cast<double>(height) / k.height;
  scaled.width = width;
  scaled.height = height;
  scaled.fx *= sx;
  scaled.cx *= sx;
  scaled.fy *= sy;
  scaled.cy *= sy;
  return scaled;
}

SimRgbdSensor::SimRgbdSensor(drivers::DeviceInfo info, SimRgbdOptions options, PinholeCamera depth_camera,
                             std::shared_ptr<const TruthSource> truth, std::shared_ptr<Clock> clock,
                             std::shared_ptr<DeviceLink> link)
    : info_(std::move(info)),
      options_(std::move(options)),
      native_depth_camera_(depth_camera),
      truth_(std::move(truth)),
      clock_(std::move(clock)),
      link_(std::move(link)) {
  RELUME_CHECK(truth_ != nullptr && clock_ != nullptr);
  ThrowIfInvalid(options_, ("simulated RGB-D sensor " + info_.FullId()).c_str());
  ThrowIfInvalid(native_depth_camera_.intrinsics, ("simulated RGB-D sensor " + info_.FullId() + " intrinsics").c_str());
  if (!link_) link_ = std::make_shared<DeviceLink>(FaultPlan{}, clock_);
  if (!link_->Present()) throw DeviceError(DeviceErrorKind::kNotFound, info_.FullId(), "the device is unplugged");
  if (!link_->TryClaim())
    throw DeviceError(DeviceErrorKind::kAccessDenied, info_.FullId(),
                      "already opened by another handle; close it first");
  generation_ = link_->generation();
  OfferNativeSize();
  config_ = options_.configs.front();
}

// The sensor also offers its depth camera's own size (a rig's `camera:`), after the standard
// streams, so a capture can record what the rig asks for instead of 640x480.
void SimRgbdSensor::OfferNativeSize() {
  const int width = native_depth_camera_.intrinsics.width, height = native_depth_camera_.intrinsics.height;
  const bool offered = std::any_of(options_.configs.begin(), options_.configs.end(), [&](const RgbdStreamConfig& c) {
    return c.depth_width == width && c.depth_height == height;
  });
  if (offered) return;
  const RgbdStreamConfig model = options_.configs.front();
  for (bool registered : {true, false}) {
    for (bool sync : {true, false}) {
      RgbdStreamConfig config = model;
      config.depth_width = config.color_width = width;
      config.depth_height = config.color_height = height;
      config.register_depth_to_color = registered;
      config.sync_depth_and_color = sync;
      options_.configs.push_back(config);
    }
  }
}

SimRgbdSensor::~SimRgbdSensor() {
  Stop();
  link_->Release();
}

std::vector<RgbdStreamConfig> SimRgbdSensor::SupportedConfigs() const {
  return options_.configs;
}

void SimRgbdSensor::ThrowIfGone() const {
  if (link_->generation() != generation_)
    throw DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(),
                      "the sensor was unplugged; reopen it when it is enumerated again");
}

PinholeCamera SimRgbdSensor::depth_camera() const {
  return depth_camera_;
}
PinholeCamera SimRgbdSensor::color_camera() const {
  return color_camera_;
}

void SimRgbdSensor::Start(const RgbdStreamConfig& config) {
  ThrowIfGone();
  if (running_) Stop();
  const bool offered = std::any_of(options_.configs.begin(), options_.configs.end(),
                                   [&](const RgbdStreamConfig& c) { return SameConfig(c, config); });
  if (!offered) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(),
                      "stream " + std::to_string(config.depth_width) + "x" + std::to_string(config.depth_height) +
                          " depth, " + std::to_string(config.color_width) + "x" + std::to_string(config.color_height) +
                          " colour at " + std::to_string(config.fps) + " fps is not offered (see SupportedConfigs())");
  }
  config_ = config;
  depth_options_ = options_.depth;
  if (depth_options_.disparity_focal_px == 0.0) depth_options_.disparity_focal_px = native_depth_camera_.intrinsics.fx;
  depth_camera_.intrinsics = ScaleIntrinsics(native_depth_camera_.intrinsics, config.depth_width, config.depth_height);
  depth_camera_.world_from_camera = native_depth_camera_.world_from_camera;
  color_camera_.intrinsics =
      PinholeIntrinsics::FromHorizontalFov(config.color_width, config.color_height, options_.color_horizontal_fov_rad);
  color_camera_.world_from_camera = native_depth_camera_.world_from_camera * options_.color_from_depth.inverse();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.clear();
    unplugged_ = false;
  }
  start_monotonic_ = clock_->NowMonotonic();
  start_utc_ = clock_->NowUtc();
  running_ = true;
  producer_ = std::thread([this] {
    try {
      Produce();
    } catch (const std::exception& e) {
      // A failure inside the simulation (e.g. the truth source threw) ends the stream; the
      // consumer sees it as an I/O error instead of the process terminating.
      const MonotonicTime now = clock_->NowMonotonic();
      std::lock_guard<std::mutex> lock(mutex_);
      running_ = false;  // before the error is visible, so a consumer that sees it sees this too
      queue_.push_back(
          {DeviceError(DeviceErrorKind::kIo, info_.FullId(), std::string("stream failed: ") + e.what()), now});
      changed_.notify_all();
    }
  });
}

void SimRgbdSensor::Stop() {
  {
    // Under the lock, so that a producer about to wait for queue space cannot miss the wake-up.
    std::lock_guard<std::mutex> lock(mutex_);
    running_ = false;
  }
  changed_.notify_all();
  if (producer_.joinable()) producer_.join();
}

bool SimRgbdSensor::WaitUntil(MonotonicTime due) {
  while (running_) {
    const Nanoseconds left = due - clock_->NowMonotonic();
    if (left.count() <= 0) return true;
    if (options_.pacing == SimRgbdOptions::Pacing::kClockSleep) {
      // In slices, so that Stop() is not held up by a long stall.
      clock_->SleepFor(std::min<Nanoseconds>(left, std::chrono::milliseconds(50)));
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  return false;
}

void SimRgbdSensor::Push(Item item) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (static_cast<int>(queue_.size()) >= options_.queue_capacity) {
    if (options_.queue_full == SimRgbdOptions::QueueFull::kDropOldest) {
      queue_.pop_front();
      ++overflow_drops_;
    } else {
      changed_.wait(lock, [&] { return !running_ || static_cast<int>(queue_.size()) < options_.queue_capacity; });
      if (!running_) return;
    }
  }
  queue_.push_back(std::move(item));
  changed_.notify_all();
}

RgbdFrame SimRgbdSensor::MakeFrame(std::uint64_t frame_number, MonotonicTime exposure_monotonic) {
  const UtcTime depth_utc = start_utc_ + (exposure_monotonic - start_monotonic_);
  const GroundTruth depth_truth = truth_->Render(depth_camera_, depth_utc);
  cv::Mat depth = MeasureDepth(depth_truth.depth_m, depth_truth.normal_in_world, depth_camera_, depth_options_,
                               StreamSeed(options_.seed, frame_number));
  const Nanoseconds color_delay =
      config_.sync_depth_and_color ? Nanoseconds{0} : Seconds(options_.unsynced_color_delay_s);
  const GroundTruth color_truth = truth_->Render(color_camera_, depth_utc + color_delay);
  ExposureParams exposure = options_.color_exposure;
  if (options_.color_auto_exposure) {
    exposure.exposure_time_s = MeterExposure(color_truth.radiance, color_camera_.intrinsics, exposure,
                                             options_.color_model, options_.color_metering)
                                   .exposure_time_s;
  }
  cv::Mat electrons = ExpectedElectrons(color_truth.radiance, color_camera_.intrinsics, exposure, options_.color_model);
  if (options_.color_noise) {
    electrons = AddSensorNoise(electrons, options_.color_model, StreamSeed(options_.seed ^ 0xc0102ULL, frame_number));
  }

  RgbdFrame frame;
  frame.device_id = info_.FullId();
  frame.color = EncodedFromElectrons(electrons, exposure, options_.color_model);
  frame.color_intrinsics = color_camera_.intrinsics;
  frame.color_exposure.exposure_time_s = exposure.exposure_time_s;
  frame.color_exposure.aperture_f = exposure.aperture_f;
  frame.color_exposure.iso = exposure.iso;
  frame.color_exposure.gain_db = exposure.gain_db;
  if (config_.register_depth_to_color) {
    frame.depth_m =
        RegisterDepthToColor(depth, depth_camera_.intrinsics, color_camera_.intrinsics, options_.color_from_depth,
                             options_.registration, depth_options_.edge_jump_fraction);
    frame.depth_intrinsics = color_camera_.intrinsics;
    frame.registered_to_color = true;
    frame.color_from_depth = Eigen::Isometry3d::Identity();
  } else {
    frame.depth_m = depth;
    frame.depth_intrinsics = depth_camera_.intrinsics;
    frame.color_from_depth = options_.color_from_depth;
  }
  const Nanoseconds jumps = link_->clock_jumps();
  frame.depth_timing.device_timestamp = options_.device_clock.DeviceTime(exposure_monotonic, jumps);
  frame.color_timing.device_timestamp = options_.device_clock.DeviceTime(exposure_monotonic + color_delay, jumps);
  frame.depth_timing.sequence = frame.color_timing.sequence = frame_number;
  return frame;
}

void SimRgbdSensor::Produce() {
  const double period_s = 1.0 / config_.fps;
  for (std::uint64_t slot = 0; running_; ++slot) {
    const auto [frame_number, faults] = link_->NextFrame();
    Rng rng(StreamSeed(options_.seed ^ 0x6a17ULL, frame_number));
    const double jitter_s = std::clamp(options_.frame_jitter_s * rng.Normal(), -0.25 * period_s, 0.25 * period_s);
    MonotonicTime due = start_monotonic_ + Seconds(static_cast<double>(slot) * period_s + jitter_s);
    if (faults.timeout) due += Seconds(link_->plan().timeout_duration_s);  // the stream stalls
    if (!WaitUntil(due)) return;
    if (faults.disconnect) {
      link_->Unplug();
      std::lock_guard<std::mutex> lock(mutex_);
      unplugged_ = true;
      changed_.notify_all();
      return;
    }
    if (faults.drop) continue;
    std::variant<RgbdFrame, DeviceError> content = MakeFrame(frame_number, due);
    if (faults.corrupt || faults.truncate) {
      // Only damaged frames go through the byte-level check: an intact frame always passes it.
      const cv::Mat& depth = std::get<RgbdFrame>(content).depth_m;
      std::vector<std::uint8_t> bytes(depth.total() * depth.elemSize());
      std::memcpy(bytes.data(), depth.data, bytes.size());
      try {
        TransferAndCheck(bytes, faults, options_.seed, frame_number, info_.FullId());
      } catch (const DeviceError& e) {
        content = e;
      }
    }
    if (options_.pacing == SimRgbdOptions::Pacing::kClockSleep) clock_->SleepFor(Seconds(options_.transfer_latency_s));
    const MonotonicTime arrival = clock_->NowMonotonic();
    if (auto* frame = std::get_if<RgbdFrame>(&content)) {
      frame->depth_timing.host_utc = frame->color_timing.host_utc = clock_->NowUtc();
      frame->depth_timing.host_monotonic = frame->color_timing.host_monotonic = arrival;
    }
    Push({std::move(content), arrival});
  }
}

RgbdFrame SimRgbdSensor::WaitForFrame(Nanoseconds timeout) {
  const MonotonicTime deadline = clock_->NowMonotonic() + timeout;
  const auto real_deadline = std::chrono::steady_clock::now() + timeout;
  const bool follow = options_.pacing == SimRgbdOptions::Pacing::kFollowClock;
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    if (!queue_.empty()) {
      if (queue_.front().arrival > deadline && !follow) break;  // it came too late for this call
      Item item = std::move(queue_.front());
      queue_.pop_front();
      changed_.notify_all();
      if (auto* error = std::get_if<DeviceError>(&item.content)) throw *error;
      return std::get<RgbdFrame>(std::move(item.content));
    }
    if (unplugged_ || link_->generation() != generation_)
      throw DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(), "the sensor was unplugged while streaming");
    if (!running_)
      throw DeviceError(DeviceErrorKind::kTimeout, info_.FullId(), "not streaming: call Start() before WaitForFrame()");
    if (clock_->NowMonotonic() >= deadline) break;
    if (follow && std::chrono::steady_clock::now() >= real_deadline) break;
    changed_.wait_for(lock, std::chrono::microseconds(500));
  }
  throw DeviceError(DeviceErrorKind::kTimeout, info_.FullId(),
                    "no frame within " + std::to_string(std::chrono::duration<double>(timeout).count()) + " s");
}

}  // namespace relume::sim
