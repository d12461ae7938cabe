// Every injected fault surfaces as its typed DeviceError (or, for drops and clock jumps, as its
// observable effect), and the retry/reconnect wrappers of drivers/retry.h recover through them.
#include "sim/devices/faults.h"

#include <gtest/gtest.h>

#include <fstream>

#include "drivers/device_error.h"
#include "drivers/retry.h"
#include "sim/devices/sim_backend.h"
#include "sim/devices/test_rig.h"

namespace relume::sim {
namespace {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::DeviceEvent;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing::LookingAtWall;
using testing::TestRig;

// A sim backend with one still camera "cam0" under `faults`.
struct FaultyRig : TestRig {
  std::shared_ptr<SimBackend> backend;
  drivers::DeviceRegistry registry;
  explicit FaultyRig(const FaultPlan& faults) {
    SimDeviceSpec spec;
    spec.id = "cam0";
    spec.camera = LookingAtWall(16, 12);
    spec.still.add_noise = false;
    spec.faults = faults;
    backend = std::make_shared<SimBackend>(std::vector<SimDeviceSpec>{spec}, truth, clock);
    registry.Add(backend);
  }
  std::unique_ptr<drivers::StillCamera> Open() { return registry.OpenStillCamera(registry.Find("sim:cam0")); }
};

struct CaptureOutcome {
  std::optional<DeviceErrorKind> error;
  std::string message;
};
CaptureOutcome Try(drivers::StillCamera& camera) {
  try {
    camera.Capture();
    return {};
  } catch (const DeviceError& e) {
    return {e.kind(), e.what()};
  }
}

TEST(SimFaultsTest, EachStillCameraFaultSurfacesAsItsTypedError) {
  FaultPlan plan;
  plan.timeout_frames = {2};
  plan.busy_frames = {3};
  plan.corrupt_frames = {4};
  plan.truncate_frames = {5};
  plan.disconnect_at_frame = 6;
  plan.timeout_duration_s = 1.5;
  FaultyRig rig(plan);
  auto camera = rig.Open();
  EXPECT_FALSE(Try(*camera).error);  // frame 1
  const MonotonicTime before_timeout = rig.clock->NowMonotonic();
  CaptureOutcome outcome = Try(*camera);
  EXPECT_EQ(outcome.error, DeviceErrorKind::kTimeout);
  EXPECT_GE(rig.clock->NowMonotonic() - before_timeout, milliseconds(1500)) << "a timeout takes its time";
  outcome = Try(*camera);
  EXPECT_EQ(outcome.error, DeviceErrorKind::kBusy);
  EXPECT_NE(outcome.message.find("PTP device busy"), std::string::npos);
  outcome = Try(*camera);
  EXPECT_EQ(outcome.error, DeviceErrorKind::kCorruptFrame);
  EXPECT_NE(outcome.message.find("checksum"), std::string::npos) << outcome.message;
  outcome = Try(*camera);
  EXPECT_EQ(outcome.error, DeviceErrorKind::kCorruptFrame);
  EXPECT_NE(outcome.message.find("truncated"), std::string::npos) << outcome.message;
  EXPECT_EQ(Try(*camera).error, DeviceErrorKind::kDisconnected);
  // Gone: the old handle stays dead, enumeration does not list it, opening says not found.
  EXPECT_EQ(Try(*camera).error, DeviceErrorKind::kDisconnected);
  EXPECT_TRUE(rig.registry.Enumerate().empty());
  drivers::DeviceInfo info;
  info.backend = "sim";
  info.id = "cam0";
  try {
    rig.backend->OpenStillCamera(info);
    FAIL() << "opened an unplugged camera";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kNotFound);
  }
  camera.reset();
  // Back after reconnect_after_s (5 s default) of clock time; frame numbers carry on.
  rig.clock->Advance(seconds(5));
  ASSERT_EQ(rig.registry.Enumerate().size(), 1u);
  auto again = rig.Open();
  const drivers::StillFrame frame = again->Capture();
  EXPECT_EQ(frame.timing.sequence, 7u);
}

TEST(SimFaultsTest, ClockJumpShowsInTheDeviceTimestamp) {
  FaultPlan plan;
  plan.clock_jumps_s[3] = 0.75;
  FaultyRig rig(plan);
  auto camera = rig.Open();
  std::vector<double> device_minus_host;
  for (int i = 0; i < 4; ++i) {
    rig.clock->Advance(seconds(1));
    const drivers::StillFrame frame = camera->Capture();
    device_minus_host.push_back(std::chrono::duration<double>(*frame.timing.device_timestamp).count() -
                                std::chrono::duration<double>(frame.timing.host_monotonic.time_since_epoch()).count());
  }
  // host_monotonic is after the exposure (1/125 s); the device stamps its start.
  EXPECT_NEAR(device_minus_host[1] - device_minus_host[0], 0.0, 1e-9);
  EXPECT_NEAR(device_minus_host[2] - device_minus_host[1], 0.75, 1e-9);
  EXPECT_NEAR(device_minus_host[3] - device_minus_host[2], 0.0, 1e-9);
}

TEST(SimFaultsTest, RandomFaultsRepeatWithTheSeedAndFollowTheirRates) {
  FaultPlan plan;
  plan.seed = 17;
  plan.busy_probability = 0.2;
  plan.drop_probability = 0.05;
  int busy = 0, drops = 0, differ = 0;
  FaultPlan other = plan;
  other.seed = 18;
  for (std::uint64_t frame = 1; frame <= 20000; ++frame) {
    const FrameFaults a = FaultsForFrame(plan, frame), b = FaultsForFrame(plan, frame);
    ASSERT_EQ(a.busy, b.busy);
    ASSERT_EQ(a.drop, b.drop);
    busy += a.busy;
    drops += a.drop;
    differ += a.busy != FaultsForFrame(other, frame).busy;
    EXPECT_FALSE(a.timeout || a.corrupt || a.disconnect);
  }
  EXPECT_NEAR(busy / 20000.0, 0.2, 0.01);
  EXPECT_NEAR(drops / 20000.0, 0.05, 0.005);
  EXPECT_GT(differ, 1000);
}

TEST(SimFaultsTest, RetryingCameraRecoversThroughTransientFaults) {
  FaultPlan plan;
  plan.busy_frames = {1, 2};
  plan.timeout_frames = {3};
  plan.corrupt_frames = {4};
  plan.truncate_frames = {5};
  FaultyRig rig(plan);
  std::vector<DeviceEvent> events;
  drivers::RetryPolicy policy;
  policy.max_attempts = 6;
  drivers::RetryingStillCamera camera(
      rig.Open(), policy, [&](const DeviceEvent& e) { events.push_back(e); },
      [&](Nanoseconds d) { rig.clock->SleepFor(d); });
  const drivers::StillFrame frame = camera.Capture();
  EXPECT_EQ(frame.timing.sequence, 6u);
  ASSERT_EQ(events.size(), 5u);
  const std::vector<DeviceErrorKind> expected = {DeviceErrorKind::kBusy, DeviceErrorKind::kBusy,
                                                 DeviceErrorKind::kTimeout, DeviceErrorKind::kCorruptFrame,
                                                 DeviceErrorKind::kCorruptFrame};
  for (std::size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].type, DeviceEvent::Type::kRetry);
    EXPECT_EQ(events[i].error, expected[i]) << i;
  }
}

TEST(SimFaultsTest, ReconnectingCameraWaitsForTheDeviceToComeBack) {
  FaultPlan plan;
  plan.disconnect_at_frame = 2;
  plan.reconnect_after_s = 2.5;
  FaultyRig rig(plan);
  std::vector<DeviceEvent> events;
  drivers::RetryPolicy policy;
  policy.initial_backoff = seconds(1);
  policy.max_attempts = 4;
  drivers::ReconnectingStillCamera camera(
      rig.Open(), [&] { return rig.Open(); }, policy, [&](const DeviceEvent& e) { events.push_back(e); },
      [&](Nanoseconds d) { rig.clock->SleepFor(d); });
  drivers::ExposureSettings settings;
  settings.exposure_time_s = 1.0 / 60;
  camera.Apply(settings);
  EXPECT_EQ(camera.Capture().timing.sequence, 1u);
  const drivers::StillFrame after = camera.Capture();  // frame 2 unplugs; reopen, re-apply, repeat
  EXPECT_EQ(after.timing.sequence, 3u);
  EXPECT_DOUBLE_EQ(after.exposure.exposure_time_s, 1.0 / 60) << "settings re-applied after the reconnect";
  // Attempts after 1 s (still away) and 1 + 2 = 3 s (back, since 2.5 s had passed).
  ASSERT_GE(events.size(), 3u);
  EXPECT_EQ(events[0].type, DeviceEvent::Type::kReconnectAttempt);
  EXPECT_EQ(events[1].type, DeviceEvent::Type::kReconnectAttempt);
  EXPECT_NE(events[1].message.find("no such device"), std::string::npos) << events[1].message;
  EXPECT_EQ(events.back().type, DeviceEvent::Type::kReconnected);
  EXPECT_EQ(events.back().attempt, 2);
}

TEST(SimFaultsTest, PlanFromYamlWithErrorsNamingTheKey) {
  const std::string path = ::testing::TempDir() + "/faults_test.yaml";
  {
    std::ofstream out(path);
    out << "faults:\n  seed: 9\n  disconnect_at_frame: 4\n  reconnect_after_s: 1.5\n  busy_frames: [1, 3]\n"
           "  drop_frames: [7]\n  clock_jumps:\n    - {frame: 5, jump_s: -0.2}\n  corrupt_probability: 0.1\n";
  }
  const YamlFile file(path);
  const FaultPlan plan = ParseFaultPlan(file, file.root()["faults"]);
  EXPECT_EQ(plan.seed, 9u);
  EXPECT_EQ(plan.disconnect_at_frame, 4u);
  EXPECT_EQ(plan.reconnect_after_s, 1.5);
  EXPECT_EQ(plan.busy_frames, (std::set<std::uint64_t>{1, 3}));
  EXPECT_EQ(plan.drop_frames, (std::set<std::uint64_t>{7}));
  EXPECT_EQ(plan.clock_jumps_s.at(5), -0.2);
  EXPECT_EQ(plan.corrupt_probability, 0.1);
  {
    std::ofstream out(path);
    out << "faults:\n  busy_frames: [0]\n";
  }
  const YamlFile bad(path);
  try {
    ParseFaultPlan(bad, bad.root()["faults"]);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "busy_frames");
    EXPECT_EQ(e.line(), 2);
  }
  {
    std::ofstream out(path);
    out << "faults:\n  busy_probablity: 0.1\n";
  }
  const YamlFile typo(path);
  EXPECT_THROW(ParseFaultPlan(typo, typo.root()["faults"]), ConfigError);
}

}  // namespace
}  // namespace relume::sim
