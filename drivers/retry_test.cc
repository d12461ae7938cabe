#include "drivers/retry.h"

#include <gtest/gtest.h>

#include "drivers/testing_camera.h"

namespace relume::drivers {
namespace {

using std::chrono::milliseconds;
using testing::ScriptedCamera;

struct Recorder {
  std::vector<DeviceEvent> events;
  std::vector<Nanoseconds> sleeps;
  DeviceEventSink Sink() {
    return [this](const DeviceEvent& e) { events.push_back(e); };
  }
  SleepFunction Sleep() {
    return [this](Nanoseconds d) { sleeps.push_back(d); };
  }
};

TEST(RetryTest, BusyIsRetriedWithExponentialBackoff) {
  auto inner = std::make_unique<ScriptedCamera>();
  inner->script = {DeviceErrorKind::kBusy, DeviceErrorKind::kBusy, DeviceErrorKind::kTimeout, std::nullopt};
  ScriptedCamera* raw = inner.get();
  Recorder recorder;
  RetryPolicy policy;
  policy.initial_backoff = milliseconds(100);
  RetryingStillCamera camera(std::move(inner), policy, recorder.Sink(), recorder.Sleep());
  const StillFrame frame = camera.Capture();
  EXPECT_EQ(frame.timing.sequence, 1u);
  EXPECT_EQ(raw->captures, 1);
  ASSERT_EQ(recorder.events.size(), 3u);
  EXPECT_EQ(recorder.events[0].error, DeviceErrorKind::kBusy);
  EXPECT_EQ(recorder.events[2].error, DeviceErrorKind::kTimeout);
  EXPECT_EQ(recorder.sleeps, (std::vector<Nanoseconds>{milliseconds(100), milliseconds(200), milliseconds(400)}));
}

TEST(RetryTest, GivesUpAfterMaxAttemptsAndSaysSo) {
  auto inner = std::make_unique<ScriptedCamera>();
  inner->script = {DeviceErrorKind::kBusy, DeviceErrorKind::kBusy, DeviceErrorKind::kBusy};
  Recorder recorder;
  RetryPolicy policy;
  policy.max_attempts = 3;
  RetryingStillCamera camera(std::move(inner), policy, recorder.Sink(), recorder.Sleep());
  try {
    camera.Capture();
    FAIL() << "expected a DeviceError";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kBusy);
  }
  ASSERT_EQ(recorder.events.size(), 3u);
  EXPECT_EQ(recorder.events.back().type, DeviceEvent::Type::kGaveUp);
  EXPECT_EQ(recorder.sleeps.size(), 2u);
}

TEST(RetryTest, NonRetryableErrorsPassThroughAtOnce) {
  for (DeviceErrorKind kind :
       {DeviceErrorKind::kUnsupportedSetting, DeviceErrorKind::kDisconnected, DeviceErrorKind::kAccessDenied}) {
    auto inner = std::make_unique<ScriptedCamera>();
    inner->script = {kind, std::nullopt};
    Recorder recorder;
    RetryingStillCamera camera(std::move(inner), RetryPolicy{}, recorder.Sink(), recorder.Sleep());
    EXPECT_THROW(camera.Apply({}), DeviceError) << ToString(kind);
    EXPECT_TRUE(recorder.events.empty());
  }
}

TEST(RetryTest, BackoffIsCapped) {
  RetryPolicy policy;
  policy.initial_backoff = milliseconds(100);
  policy.max_backoff = milliseconds(250);
  EXPECT_EQ(policy.BackoffAfter(1), milliseconds(100));
  EXPECT_EQ(policy.BackoffAfter(2), milliseconds(200));
  EXPECT_EQ(policy.BackoffAfter(10), milliseconds(250));
  policy.max_attempts = 0;
  std::string why;
  EXPECT_FALSE(policy.IsValid(&why));
  EXPECT_THROW(RetryingStillCamera(std::make_unique<ScriptedCamera>(), policy, nullptr), InvalidArgumentError);
}

TEST(ReconnectTest, ReopensReappliesSettingsAndRepeatsTheCall) {
  auto first = std::make_unique<ScriptedCamera>();
  first->script = {std::nullopt, DeviceErrorKind::kDisconnected};  // Apply ok, then unplugged
  int reopens = 0;
  ScriptedCamera* second_raw = nullptr;
  auto reopen = [&]() -> std::unique_ptr<StillCamera> {
    ++reopens;
    if (reopens == 1) throw DeviceError(DeviceErrorKind::kNotFound, "test:cam0", "still unplugged");
    auto second = std::make_unique<ScriptedCamera>();
    second_raw = second.get();
    return second;
  };
  Recorder recorder;
  ReconnectingStillCamera camera(std::move(first), reopen, RetryPolicy{}, recorder.Sink(), recorder.Sleep());
  ExposureSettings settings;
  settings.exposure_time_s = 1.0 / 250;
  camera.Apply(settings);
  const StillFrame frame = camera.Capture();
  EXPECT_EQ(reopens, 2);
  ASSERT_NE(second_raw, nullptr);
  EXPECT_EQ(second_raw->captures, 1);
  ASSERT_TRUE(second_raw->last_applied.exposure_time_s);
  EXPECT_DOUBLE_EQ(*second_raw->last_applied.exposure_time_s, 1.0 / 250);
  EXPECT_EQ(recorder.events.back().type, DeviceEvent::Type::kReconnected);
  EXPECT_EQ(frame.device_id, "test:cam0");
}

TEST(ReconnectTest, GivesUpWithAClearMessage) {
  auto first = std::make_unique<ScriptedCamera>();
  first->script = {DeviceErrorKind::kDisconnected};
  auto reopen = []() -> std::unique_ptr<StillCamera> {
    throw DeviceError(DeviceErrorKind::kNotFound, "test:cam0", "not on the bus");
  };
  RetryPolicy policy;
  policy.max_attempts = 2;
  Recorder recorder;
  ReconnectingStillCamera camera(std::move(first), reopen, policy, recorder.Sink(), recorder.Sleep());
  try {
    camera.Capture();
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kDisconnected);
    EXPECT_NE(std::string(e.what()).find("check the cable"), std::string::npos) << e.what();
  }
  EXPECT_EQ(recorder.events.back().type, DeviceEvent::Type::kGaveUp);
  // Later calls try again instead of crashing on a missing device.
  EXPECT_THROW(camera.Capture(), DeviceError);
}

}  // namespace
}  // namespace relume::drivers
