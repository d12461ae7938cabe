// A streaming depth + colour sensor (OpenNI2 devices, the simulator).
#pragma once

#include <string>
#include <vector>

#include "core/time.h"
#include "drivers/device_info.h"
#include "drivers/frame.h"

namespace relume::drivers {

struct RgbdStreamConfig {
  int depth_width = 640;
  int depth_height = 480;
  int color_width = 640;
  int color_height = 480;
  double fps = 30.0;
  bool register_depth_to_color = true;
  bool sync_depth_and_color = true;
  bool IsValid(std::string* why) const;
  // "depth 640x480 + colour 640x480 @ 30 fps, registered, synced" (as `relume devices` lists it).
  std::string Describe() const;
};

class RgbdSensor {
 public:
  virtual ~RgbdSensor() = default;
  virtual const DeviceInfo& info() const = 0;
  virtual std::vector<RgbdStreamConfig> SupportedConfigs() const = 0;
  // Starts streaming; a config not among SupportedConfigs() throws kUnsupportedSetting.
  virtual void Start(const RgbdStreamConfig& config) = 0;
  virtual void Stop() = 0;
  virtual bool streaming() const = 0;
  // The next frame; throws DeviceError(kTimeout) when none arrives within `timeout`, and
  // kDisconnected when the sensor is gone.
  virtual RgbdFrame WaitForFrame(Nanoseconds timeout) = 0;
};

}  // namespace relume::drivers
