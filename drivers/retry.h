// Retries and reconnects as wrappers around the device interfaces (librealsense style): the
// wrapped device stays simple, and the capture layer sees every retry as an event.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "drivers/device_error.h"
#include "drivers/still_camera.h"

namespace relume::drivers {

struct RetryPolicy {
  int max_attempts = 5;  // tries of one call, the first included
  Nanoseconds initial_backoff = std::chrono::milliseconds(100);
  double backoff_multiplier = 2.0;
  Nanoseconds max_backoff = std::chrono::seconds(5);
  bool IsValid(std::string* why) const;
  // The wait before try number `attempt` + 1 (attempt >= 1).
  Nanoseconds BackoffAfter(int attempt) const;
};

// Something that happened to a device that the capture layer records as a session event.
struct DeviceEvent {
  enum class Type { kRetry, kGaveUp, kReconnectAttempt, kReconnected };
  Type type = Type::kRetry;
  std::string device_id;
  DeviceErrorKind error = DeviceErrorKind::kIo;
  int attempt = 0;
  Nanoseconds wait{0};
  std::string message;
};
const char* ToString(DeviceEvent::Type type);

using DeviceEventSink = std::function<void(const DeviceEvent&)>;
// Waits; injectable so that simulated rigs can run on a simulated clock.
using SleepFunction = std::function<void(Nanoseconds)>;
SleepFunction RealSleep();

// Retries calls that fail with a retryable DeviceError (busy, timeout, I/O, corrupt frame)
// with exponential backoff. Other errors pass through at once.
class RetryingStillCamera : public StillCamera {
 public:
  RetryingStillCamera(std::unique_ptr<StillCamera> inner, RetryPolicy policy, DeviceEventSink events,
                      SleepFunction sleep = RealSleep());
  const DeviceInfo& info() const override { return inner_->info(); }
  ExposureCapabilities capabilities() const override { return inner_->capabilities(); }
  void Apply(const ExposureSettings& settings) override;
  StillFrame Capture() override;

 private:
  template <typename Call>
  auto WithRetries(Call&& call) -> decltype(call());

  std::unique_ptr<StillCamera> inner_;
  RetryPolicy policy_;
  DeviceEventSink events_;
  SleepFunction sleep_;
};

// Reopens a camera that disconnected (through `reopen`, typically DeviceRegistry::Find +
// OpenStillCamera by the same id), re-applies the last settings, and repeats the call.
class ReconnectingStillCamera : public StillCamera {
 public:
  using Opener = std::function<std::unique_ptr<StillCamera>()>;
  ReconnectingStillCamera(std::unique_ptr<StillCamera> inner, Opener reopen, RetryPolicy policy, DeviceEventSink events,
                          SleepFunction sleep = RealSleep());
  const DeviceInfo& info() const override { return info_; }
  ExposureCapabilities capabilities() const override;
  void Apply(const ExposureSettings& settings) override;
  StillFrame Capture() override;

 private:
  void Reconnect(const DeviceError& cause);
  template <typename Call>
  auto WithReconnect(Call&& call) -> decltype(call());

  std::unique_ptr<StillCamera> inner_;
  Opener reopen_;
  RetryPolicy policy_;
  DeviceEventSink events_;
  SleepFunction sleep_;
  DeviceInfo info_;
  ExposureSettings applied_;  // everything applied so far, merged
};

}  // namespace relume::drivers
