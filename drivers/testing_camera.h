// A scripted StillCamera for testing the wrappers in this folder: each call pops the next
// scripted outcome (a frame or a DeviceError). It stands in for no real device and is not
// linked into relume itself.
#pragma once

#include <deque>
#include <optional>

#include "drivers/device_error.h"
#include "drivers/still_camera.h"

namespace relume::drivers::testing {

class ScriptedCamera : public StillCamera {
 public:
  explicit ScriptedCamera(std::string id = "cam0") {
    info_.backend = "test";
    info_.id = std::move(id);
  }
  // Outcome of the next call: an error kind, or nothing for success.
  std::deque<std::optional<DeviceErrorKind>> script;
  int captures = 0;
  int applies = 0;
  ExposureSettings last_applied;

  const DeviceInfo& info() const override { return info_; }
  ExposureCapabilities capabilities() const override { return {}; }
  void Apply(const ExposureSettings& settings) override {
    Next();
    ++applies;
    last_applied = settings;
  }
  StillFrame Capture() override {
    Next();
    StillFrame frame;
    frame.device_id = info_.FullId();
    frame.timing.sequence = static_cast<std::uint64_t>(++captures);
    return frame;
  }

 private:
  void Next() {
    if (script.empty()) return;
    const std::optional<DeviceErrorKind> outcome = script.front();
    script.pop_front();
    if (outcome) throw DeviceError(*outcome, info_.FullId(), "scripted failure");
  }
  DeviceInfo info_;
};

}  // namespace relume::drivers::testing
