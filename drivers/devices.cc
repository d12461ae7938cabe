#include <cmath>
#include <sstream>

#include "drivers/backend.h"
#include "drivers/device_error.h"
#include "drivers/rgbd_sensor.h"
#include "drivers/still_camera.h"

namespace relume::drivers {

const char* ToString(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::kStillCamera: return "still_camera";
    case DeviceKind::kRgbdSensor: return "rgbd_sensor";
  }
  return "unknown";
}

const char* ToString(ExposureControl control) {
  switch (control) {
    case ExposureControl::kShutterList: return "shutter_list";
    case ExposureControl::kContinuous: return "continuous";
    case ExposureControl::kEvOnly: return "ev_only";
  }
  return "unknown";
}

bool RgbdStreamConfig::IsValid(std::string* why) const {
  if (depth_width <= 0 || depth_height <= 0 || color_width <= 0 || color_height <= 0) {
    if (why) *why = "stream sizes must be positive";
    return false;
  }
  if (!(std::isfinite(fps) && fps > 0.0 && fps <= 1000.0)) {
    if (why) *why = "fps must be within (0, 1000]";
    return false;
  }
  return true;
}

std::string RgbdStreamConfig::Describe() const {
  std::ostringstream s;
  s << "depth " << depth_width << "x" << depth_height << " + colour " << color_width << "x" << color_height << " @ "
    << fps << " fps, " << (register_depth_to_color ? "registered" : "unregistered") << ", "
    << (sync_depth_and_color ? "synced" : "unsynced");
  return s.str();
}

void DeviceRegistry::Add(std::shared_ptr<Backend> backend) {
  RELUME_CHECK(backend != nullptr);
  for (const auto& existing : backends_) {
    RELUME_CHECK_MSG(existing->name() != backend->name(), "backend added twice: " + backend->name());
  }
  backends_.push_back(std::move(backend));
}

std::vector<DeviceInfo> DeviceRegistry::Enumerate(std::vector<std::string>* problems) const {
  std::vector<DeviceInfo> all;
  for (const auto& backend : backends_) {
    try {
      std::vector<DeviceInfo> found = backend->Enumerate();
      all.insert(all.end(), found.begin(), found.end());
    } catch (const Error& e) {
      if (problems) problems->push_back(backend->name() + ": " + e.what());
    }
  }
  return all;
}

DeviceInfo DeviceRegistry::Find(const std::string& wanted) const {
  const std::vector<DeviceInfo> all = Enumerate();
  std::vector<DeviceInfo> matches;
  for (const DeviceInfo& info : all) {
    if (info.FullId() == wanted || info.id == wanted) matches.push_back(info);
  }
  if (matches.size() == 1) return matches.front();
  std::string available;
  for (const DeviceInfo& info : all) available += (available.empty() ? "" : ", ") + info.FullId();
  if (matches.empty()) {
    throw DeviceError(DeviceErrorKind::kNotFound, wanted,
                      "no such device; available: " + (available.empty() ? std::string("none") : available) +
                          " (is it plugged in and powered? `relume devices` lists what is seen)");
  }
  throw DeviceError(DeviceErrorKind::kNotFound, wanted, "ambiguous; name it as backend:id, one of: " + available);
}

Backend& DeviceRegistry::BackendFor(const DeviceInfo& info) const {
  for (const auto& backend : backends_) {
    if (backend->name() == info.backend) return *backend;
  }
  throw DeviceError(DeviceErrorKind::kNotFound, info.FullId(),
                    "backend '" + info.backend + "' is not part of this build");
}

std::unique_ptr<StillCamera> DeviceRegistry::OpenStillCamera(const DeviceInfo& info) const {
  return BackendFor(info).OpenStillCamera(info);
}

std::unique_ptr<RgbdSensor> DeviceRegistry::OpenRgbdSensor(const DeviceInfo& info) const {
  return BackendFor(info).OpenRgbdSensor(info);
}

}  // namespace relume::drivers
