// A simulated RGB-D sensor (Kinect v1-like) behind drivers::RgbdSensor. A background thread
// produces frames at the configured rate in the Clock's time and puts them in a bounded queue;
// WaitForFrame takes them out. Depth comes from the depth model (sim/devices/depth_model.h),
// colour from the camera model (sim/devices/camera_model.h, 8-bit encoded, auto exposure),
// faults from the device's DeviceLink (sim/devices/faults.h).
//
// Geometry: the PinholeCamera given is the depth camera at its native size; the colour camera
// sits at color_from_depth (a baseline along x) with its own field of view. Stream sizes other
// than the native one scale the intrinsics. With registration on, depth is resampled into the
// colour image (RgbdFrame::registered_to_color).
//
// Timing: frame slot k is exposed at t_k = start + k / fps + jitter_k (clock time; jitter is
// Gaussian, seeded, clamped to a quarter period). Depth truth is rendered at t_k, colour at t_k
// (or t_k + unsynced_color_delay_s when depth and colour are not synchronised).
// device_timestamp = the device clock at exposure; host_utc/host_monotonic = the clock when the
// frame was queued. sequence = the device's frame number (faults.h), so dropped frames leave
// gaps.
//
// Pacing: kClockSleep waits with Clock::SleepFor (right for SystemClock and SimulatedClock; on a
// ManualClock the sensor then runs as fast as it can render, advancing the clock itself).
// kFollowClock waits for someone else to move the clock (a test stepping a ManualClock): the
// producer polls, and WaitForFrame also gives up after `timeout` of real time.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <variant>

#include "core/clock.h"
#include "drivers/device_error.h"
#include "drivers/rgbd_sensor.h"
#include "sim/devices/camera_model.h"
#include "sim/devices/depth_model.h"
#include "sim/devices/exposure_modes.h"
#include "sim/devices/faults.h"
#include "sim/truth.h"

namespace relume::sim {

struct SimRgbdOptions {
  enum class Pacing { kClockSleep, kFollowClock };
  enum class QueueFull { kDropOldest, kWait };
  DepthModelOptions depth;
  CameraModelOptions color_model;
  ExposureParams color_exposure{1.0 / 60, 2.0, 100.0, 0.0};  // time ignored when auto exposure is on
  bool color_auto_exposure = true;
  MeteringOptions color_metering{MeteringOptions::Statistic::kMedian, 0.18, 1e-4, 1.0 / 30, 4096};
  bool color_noise = true;
  double color_horizontal_fov_rad = 1.09;  // about 62.5 degrees
  Eigen::Isometry3d color_from_depth = Eigen::Isometry3d(Eigen::Translation3d(-0.025, 0.0, 0.0));
  Registration registration = Registration::kNearest;  // as hardware registration; see depth_model.h
  // 640x480 and 320x240 at 30 fps; the sensor adds its depth camera's size when it is neither.
  std::vector<drivers::RgbdStreamConfig> configs;
  double frame_jitter_s = 0.0005;
  double transfer_latency_s = 0.004;  // kClockSleep only
  double unsynced_color_delay_s = 0.008;
  int queue_capacity = 4;
  QueueFull queue_full = QueueFull::kDropOldest;
  Pacing pacing = Pacing::kClockSleep;
  DeviceClockOptions device_clock;
  std::uint64_t seed = 1;

  SimRgbdOptions();
  bool IsValid(std::string* why) const;
};

class SimRgbdSensor : public drivers::RgbdSensor {
 public:
  // `depth_camera`: the depth camera's pose and native intrinsics. `link` as for
  // SimStillCamera (nullptr: a private one without faults); claims it.
  SimRgbdSensor(drivers::DeviceInfo info, SimRgbdOptions options, PinholeCamera depth_camera,
                std::shared_ptr<const TruthSource> truth, std::shared_ptr<Clock> clock,
                std::shared_ptr<DeviceLink> link = nullptr);
  ~SimRgbdSensor() override;
  SimRgbdSensor(const SimRgbdSensor&) = delete;
  SimRgbdSensor& operator=(const SimRgbdSensor&) = delete;

  const drivers::DeviceInfo& info() const override { return info_; }
  std::vector<drivers::RgbdStreamConfig> SupportedConfigs() const override;
  void Start(const drivers::RgbdStreamConfig& config) override;
  void Stop() override;
  bool streaming() const override { return running_; }
  drivers::RgbdFrame WaitForFrame(Nanoseconds timeout) override;

  // Frames thrown away because the queue was full (kDropOldest).
  std::uint64_t overflow_drops() const { return overflow_drops_; }
  // The cameras of the running (or last) stream, scaled to its sizes.
  PinholeCamera depth_camera() const;
  PinholeCamera color_camera() const;

 private:
  struct Item {
    std::variant<drivers::RgbdFrame, drivers::DeviceError> content;
    MonotonicTime arrival;
  };
  void Produce();
  bool WaitUntil(MonotonicTime due);
  drivers::RgbdFrame MakeFrame(std::uint64_t frame_number, MonotonicTime exposure_monotonic);
  void Push(Item item);
  void ThrowIfGone() const;
  void OfferNativeSize();

  drivers::DeviceInfo info_;
  SimRgbdOptions options_;
  PinholeCamera native_depth_camera_;
  std::shared_ptr<const TruthSource> truth_;
  std::shared_ptr<Clock> clock_;
  std::shared_ptr<DeviceLink> link_;
  std::uint64_t generation_ = 0;

  drivers::RgbdStreamConfig config_;
  DepthModelOptions depth_options_;  // options_.depth with the native disparity focal length
  PinholeCamera depth_camera_, color_camera_;
  MonotonicTime start_monotonic_{};
  UtcTime start_utc_{};

  std::thread producer_;
  std::atomic<bool> running_{false};
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Item> queue_;
  bool unplugged_ = false;  // the producer saw the device go
  std::atomic<std::uint64_t> overflow_drops_{0};
};

// Intrinsics scaled to another image size (same field of view and principal point position).
PinholeIntrinsics ScaleIntrinsics(const PinholeIntrinsics& intrinsics, int width, int height);

}  // namespace relume::sim
