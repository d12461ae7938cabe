// A device backend: one per library (sim, gphoto2, aravis, openni2). Enumerate returns plain
// info structs; Open turns one into a device. A backend whose library is missing at build
// time is not compiled at all (never replaced by a stub).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "drivers/device_info.h"
#include "drivers/rgbd_sensor.h"
#include "drivers/still_camera.h"

namespace relume::drivers {

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;
  virtual std::vector<DeviceInfo> Enumerate() = 0;
  // Throws DeviceError(kNotFound) when the device is gone, kAccessDenied when it is claimed.
  // Opening a device of the other kind throws InvalidArgumentError.
  virtual std::unique_ptr<StillCamera> OpenStillCamera(const DeviceInfo& info) = 0;
  virtual std::unique_ptr<RgbdSensor> OpenRgbdSensor(const DeviceInfo& info) = 0;
};

// All backends the build has, behind one enumerate/open.
class DeviceRegistry {
 public:
  void Add(std::shared_ptr<Backend> backend);
  const std::vector<std::shared_ptr<Backend>>& backends() const { return backends_; }

  // Every device every backend sees. A backend that fails to enumerate is skipped and its
  // error appended to `problems` (when given), so one broken library does not hide the rest.
  std::vector<DeviceInfo> Enumerate(std::vector<std::string>* problems = nullptr) const;
  // Finds a device by "backend:id" (or a bare id when unique). Throws DeviceError(kNotFound)
  // listing what is available.
  DeviceInfo Find(const std::string& full_or_bare_id) const;
  std::unique_ptr<StillCamera> OpenStillCamera(const DeviceInfo& info) const;
  std::unique_ptr<RgbdSensor> OpenRgbdSensor(const DeviceInfo& info) const;

 private:
  Backend& BackendFor(const DeviceInfo& info) const;
  std::vector<std::shared_ptr<Backend>> backends_;
};

}  // namespace relume::drivers
