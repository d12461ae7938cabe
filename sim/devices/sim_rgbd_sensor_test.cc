#include "sim/devices/sim_rgbd_sensor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "sim/devices/sim_backend.h"
#include "sim/devices/test_rig.h"

namespace relume::sim {
namespace {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::RgbdFrame;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing::LookingAtWall;
using testing::TestRig;

constexpr Nanoseconds kGenerous = seconds(30);  // real-time guard for frames that do come

drivers::RgbdStreamConfig SmallConfig(bool registered = false) {
  drivers::RgbdStreamConfig config;
  config.depth_width = config.color_width = 48;
  config.depth_height = config.color_height = 36;
  config.fps = 30.0;
  config.register_depth_to_color = registered;
  config.sync_depth_and_color = true;
  return config;
}

SimRgbdOptions SmallOptions(SimRgbdOptions::Pacing pacing) {
  SimRgbdOptions options;
  options.configs = {SmallConfig(false), SmallConfig(true)};
  options.pacing = pacing;
  options.queue_full = SimRgbdOptions::QueueFull::kWait;
  options.frame_jitter_s = 0.0;
  return options;
}

// An RGB-D sensor "kinect0" in a sim backend, stepped by hand (kFollowClock).
struct RgbdRig : TestRig {
  std::shared_ptr<SimBackend> backend;
  std::unique_ptr<drivers::RgbdSensor> sensor;
  explicit RgbdRig(const FaultPlan& faults = {},
                   SimRgbdOptions options = SmallOptions(SimRgbdOptions::Pacing::kFollowClock)) {
    SimDeviceSpec spec;
    spec.id = "kinect0";
    spec.kind = drivers::DeviceKind::kRgbdSensor;
    spec.camera = LookingAtWall(48, 36, 58.0);
    spec.rgbd = options;
    spec.faults = faults;
    backend = std::make_shared<SimBackend>(std::vector<SimDeviceSpec>{spec}, truth, clock);
    sensor = backend->OpenRgbdSensor(backend->Enumerate().at(0));
  }
  // Steps the clock one frame period, then waits for the frame.
  RgbdFrame Next() {
    clock->Advance(Nanoseconds(33'333'334));
    return sensor->WaitForFrame(kGenerous);
  }
};

DeviceErrorKind KindOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const DeviceError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "expected a DeviceError";
  return DeviceErrorKind::kIo;
}

double Seconds(Nanoseconds d) {
  return std::chrono::duration<double>(d).count();
}

TEST(SimRgbdSensorTest, StreamsAtThirtyFpsWithSequenceAndTimestamps) {
  RgbdRig rig;
  rig.sensor->Start(SmallConfig());
  EXPECT_TRUE(rig.sensor->streaming());
  const RgbdFrame first = rig.sensor->WaitForFrame(kGenerous);  // slot 0 is due at once
  EXPECT_EQ(first.depth_timing.sequence, 1u);
  EXPECT_EQ(first.depth_m.type(), CV_32FC1);
  EXPECT_EQ(first.depth_m.cols, 48);
  EXPECT_EQ(first.color.pixels.type(), CV_8UC3);
  EXPECT_EQ(first.color.encoding, SampleEncoding::kCameraResponse);
  EXPECT_FALSE(first.registered_to_color);
  EXPECT_NEAR(first.color_from_depth.translation().x(), -0.025, 1e-12);
  double previous = Seconds(*first.depth_timing.device_timestamp);
  for (std::uint64_t i = 2; i <= 5; ++i) {
    const RgbdFrame frame = rig.Next();
    EXPECT_EQ(frame.depth_timing.sequence, i);
    EXPECT_EQ(frame.color_timing.sequence, i);
    const double device = Seconds(*frame.depth_timing.device_timestamp);
    EXPECT_NEAR(device - previous, 1.0 / 30, 1e-6);
    EXPECT_EQ(*frame.color_timing.device_timestamp, *frame.depth_timing.device_timestamp) << "synchronised";
    EXPECT_GE(Seconds(frame.depth_timing.host_monotonic.time_since_epoch()), device - 1e-9);
    EXPECT_EQ(frame.depth_timing.host_utc - testing::RigStart(), frame.depth_timing.host_monotonic.time_since_epoch());
    previous = device;
  }
  rig.sensor->Stop();
  EXPECT_FALSE(rig.sensor->streaming());
  EXPECT_EQ(KindOf([&] { rig.sensor->WaitForFrame(milliseconds(10)); }), DeviceErrorKind::kTimeout);
}

TEST(SimRgbdSensorTest, DepthIsTheWallsDistanceWithinTheNoiseModel) {
  RgbdRig rig;
  rig.sensor->Start(SmallConfig());
  const RgbdFrame frame = rig.sensor->WaitForFrame(kGenerous);
  // The wall at 3 m, seen straight on at the centre; the sphere covers the middle, so look at a
  // corner of the wall: z = 3 m exactly (the wall is fronto-parallel).
  const float z = frame.depth_m.at<float>(2, 2);
  ASSERT_TRUE(std::isfinite(z));
  // Tolerance: four sigmas of noise plus half a disparity step at this (tiny) focal length.
  const DepthModelOptions model;
  const double fb = frame.depth_intrinsics.fx * model.projector_baseline_m;
  const double half_step = fb / (fb / 3.0 - 0.5 * model.disparity_step_px) - 3.0;
  EXPECT_NEAR(z, 3.0, 4 * DepthSigma(3.0, 0.5, model) + half_step);
}

TEST(SimRgbdSensorTest, RegisteredDepthLivesInTheColourImage) {
  RgbdRig rig;
  rig.sensor->Start(SmallConfig(true));
  const RgbdFrame frame = rig.sensor->WaitForFrame(kGenerous);
  EXPECT_TRUE(frame.registered_to_color);
  EXPECT_TRUE(frame.color_from_depth.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(frame.depth_m.size(), frame.color.pixels.size());
  EXPECT_EQ(frame.depth_intrinsics.fx, frame.color_intrinsics.fx);
  auto* sensor = dynamic_cast<SimRgbdSensor*>(rig.sensor.get());
  ASSERT_NE(sensor, nullptr);
  const GroundTruth truth = rig.truth->Render(sensor->color_camera(), testing::RigStart());
  int compared = 0;
  for (int y = 0; y < 36; ++y) {
    for (int x = 0; x < 48; ++x) {
      const float d = frame.depth_m.at<float>(y, x), t = truth.depth_m.at<float>(y, x);
      if (!std::isfinite(d) || !std::isfinite(t)) continue;
      ++compared;
      // Noise, disparity steps and a pixel of resampling on the slanted sphere.
      EXPECT_NEAR(d, t, 0.15) << x << "," << y;
    }
  }
  EXPECT_GT(compared, 48 * 36 / 2);
}

TEST(SimRgbdSensorTest, UnofferedConfigIsRejected) {
  RgbdRig rig;
  drivers::RgbdStreamConfig config = SmallConfig();
  config.fps = 60.0;
  EXPECT_EQ(KindOf([&] { rig.sensor->Start(config); }), DeviceErrorKind::kUnsupportedSetting);
  EXPECT_FALSE(rig.sensor->streaming());
  EXPECT_EQ(KindOf([&] { rig.sensor->WaitForFrame(milliseconds(1)); }), DeviceErrorKind::kTimeout);
}

TEST(SimRgbdSensorTest, DroppedFramesLeaveSequenceGaps) {
  FaultPlan plan;
  plan.drop_frames = {3, 4};
  RgbdRig rig(plan);
  rig.sensor->Start(SmallConfig());
  std::vector<std::uint64_t> sequence = {rig.sensor->WaitForFrame(kGenerous).depth_timing.sequence};
  for (int i = 0; i < 3; ++i) {
    RgbdFrame frame = rig.Next();
    if (frame.depth_timing.sequence == 2) {  // the next frame after the gap needs three periods
      rig.clock->Advance(Nanoseconds(66'666'667));
    }
    sequence.push_back(frame.depth_timing.sequence);
  }
  EXPECT_EQ(sequence, (std::vector<std::uint64_t>{1, 2, 5, 6}));
}

TEST(SimRgbdSensorTest, CorruptAndTruncatedFramesThrowAndTheStreamGoesOn) {
  FaultPlan plan;
  plan.corrupt_frames = {2};
  plan.truncate_frames = {3};
  RgbdRig rig(plan);
  rig.sensor->Start(SmallConfig());
  EXPECT_EQ(rig.sensor->WaitForFrame(kGenerous).depth_timing.sequence, 1u);
  rig.clock->Advance(Nanoseconds(33'333'334));
  EXPECT_EQ(KindOf([&] { rig.sensor->WaitForFrame(kGenerous); }), DeviceErrorKind::kCorruptFrame);
  rig.clock->Advance(Nanoseconds(33'333'334));
  EXPECT_EQ(KindOf([&] { rig.sensor->WaitForFrame(kGenerous); }), DeviceErrorKind::kCorruptFrame);
  EXPECT_EQ(rig.Next().depth_timing.sequence, 4u);
}

TEST(SimRgbdSensorTest, StallSurfacesAsTimeoutThenFramesResume) {
  FaultPlan plan;
  plan.timeout_frames = {2};
  plan.timeout_duration_s = 1.0;
  RgbdRig rig(plan);
  rig.sensor->Start(SmallConfig());
  EXPECT_EQ(rig.sensor->WaitForFrame(kGenerous).depth_timing.sequence, 1u);
  rig.clock->Advance(Nanoseconds(33'333'334));
  EXPECT_EQ(KindOf([&] { rig.sensor->WaitForFrame(milliseconds(100)); }), DeviceErrorKind::kTimeout);
  rig.clock->Advance(seconds(1));
  const RgbdFrame late = rig.sensor->WaitForFrame(kGenerous);
  EXPECT_EQ(late.depth_timing.sequence, 2u);
  EXPECT_NEAR(Seconds(*late.depth_timing.device_timestamp), 1.0 + 1.0 / 30, 1e-6);
}

TEST(SimRgbdSensorTest, DisconnectEndsTheStreamAndHidesTheDevice) {
  FaultPlan plan;
  plan.disconnect_at_frame = 3;
  plan.reconnect_after_s = 2.0;
  RgbdRig rig(plan);
  rig.sensor->Start(SmallConfig());
  EXPECT_EQ(rig.sensor->WaitForFrame(kGenerous).depth_timing.sequence, 1u);
  EXPECT_EQ(rig.Next().depth_timing.sequence, 2u);
  rig.clock->Advance(Nanoseconds(33'333'334));
  EXPECT_EQ(KindOf([&] { rig.sensor->WaitForFrame(kGenerous); }), DeviceErrorKind::kDisconnected);
  EXPECT_TRUE(rig.backend->Enumerate().empty());
  drivers::DeviceInfo info;
  info.backend = "sim";
  info.id = "kinect0";
  EXPECT_EQ(KindOf([&] { rig.backend->OpenRgbdSensor(info); }), DeviceErrorKind::kNotFound);
  EXPECT_EQ(KindOf([&] { rig.sensor->Start(SmallConfig()); }), DeviceErrorKind::kDisconnected);
  rig.sensor.reset();
  rig.clock->Advance(seconds(2));
  ASSERT_EQ(rig.backend->Enumerate().size(), 1u);
  auto again = rig.backend->OpenRgbdSensor(info);
  again->Start(SmallConfig());
  EXPECT_EQ(again->WaitForFrame(kGenerous).depth_timing.sequence, 4u);
}

TEST(SimRgbdSensorTest, ClockJumpShowsInDeviceTimestamps) {
  FaultPlan plan;
  plan.clock_jumps_s[3] = 0.5;
  RgbdRig rig(plan);
  rig.sensor->Start(SmallConfig());
  std::vector<double> stamps = {Seconds(*rig.sensor->WaitForFrame(kGenerous).depth_timing.device_timestamp)};
  for (int i = 0; i < 3; ++i) stamps.push_back(Seconds(*rig.Next().depth_timing.device_timestamp));
  EXPECT_NEAR(stamps[1] - stamps[0], 1.0 / 30, 1e-6);
  EXPECT_NEAR(stamps[2] - stamps[1], 1.0 / 30 + 0.5, 1e-6);
  EXPECT_NEAR(stamps[3] - stamps[2], 1.0 / 30, 1e-6);
}

// Free-running on a manual clock: the sensor sleeps the clock forward itself.
TEST(SimRgbdSensorTest, JitterIsSeededAndBounded) {
  std::vector<std::vector<double>> runs;
  for (int run = 0; run < 2; ++run) {
    SimRgbdOptions options = SmallOptions(SimRgbdOptions::Pacing::kClockSleep);
    options.frame_jitter_s = 0.002;
    RgbdRig rig({}, options);
    rig.sensor->Start(SmallConfig());
    std::vector<double> intervals;
    double previous = Seconds(*rig.sensor->WaitForFrame(kGenerous).depth_timing.device_timestamp);
    for (int i = 0; i < 20; ++i) {
      const double stamp = Seconds(*rig.sensor->WaitForFrame(kGenerous).depth_timing.device_timestamp);
      intervals.push_back(stamp - previous);
      previous = stamp;
    }
    runs.push_back(intervals);
  }
  EXPECT_EQ(runs[0], runs[1]);
  double spread = 0.0;
  for (double interval : runs[0]) {
    EXPECT_GT(interval, 1.0 / 30 - 0.5 / 30);
    EXPECT_LT(interval, 1.0 / 30 + 0.5 / 30);
    spread = std::max(spread, std::abs(interval - 1.0 / 30));
  }
  EXPECT_GT(spread, 1e-4) << "jitter should show";
}

TEST(SimRgbdSensorTest, FullQueueDropsTheOldestFrames) {
  SimRgbdOptions options = SmallOptions(SimRgbdOptions::Pacing::kClockSleep);
  options.queue_full = SimRgbdOptions::QueueFull::kDropOldest;
  options.queue_capacity = 2;
  RgbdRig rig({}, options);
  rig.sensor->Start(SmallConfig());
  auto* sensor = dynamic_cast<SimRgbdSensor*>(rig.sensor.get());
  const auto give_up = std::chrono::steady_clock::now() + seconds(60);
  while (sensor->overflow_drops() < 3 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(milliseconds(5));
  }
  ASSERT_GE(sensor->overflow_drops(), 3u);
  const std::uint64_t first = rig.sensor->WaitForFrame(kGenerous).depth_timing.sequence;
  EXPECT_GT(first, 1u) << "the oldest frames were dropped";
}

// A truth source that fails: the stream ends with a typed error instead of terminating.
class FailingTruth : public TruthSource {
 public:
  GroundTruth Render(const PinholeCamera&, UtcTime) const override { throw Error("scene file vanished"); }
};

TEST(SimRgbdSensorTest, AFailingTruthSourceEndsTheStreamWithAnIoError) {
  TestRig rig;
  drivers::DeviceInfo info;
  info.backend = "sim";
  info.id = "kinect0";
  SimRgbdSensor sensor(info, SmallOptions(SimRgbdOptions::Pacing::kFollowClock), LookingAtWall(48, 36),
                       std::make_shared<FailingTruth>(), rig.clock);
  sensor.Start(SmallConfig());
  try {
    sensor.WaitForFrame(kGenerous);
    FAIL() << "expected a DeviceError";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kIo);
    EXPECT_NE(std::string(e.what()).find("scene file vanished"), std::string::npos);
  }
  EXPECT_FALSE(sensor.streaming());
}

}  // namespace
}  // namespace relume::sim
