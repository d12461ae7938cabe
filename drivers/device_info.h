// What enumeration returns: plain descriptions of devices, enough to show a user and to
// open the device later (librealsense's query_*() -> info struct, create_*(info) -> device).
#pragma once

#include <map>
#include <string>

namespace relume::drivers {

enum class DeviceKind {
  kStillCamera,  // single frames on request, with exposure control (DSLR, machine vision)
  kRgbdSensor,   // streams of depth + colour (Kinect-like)
};
const char* ToString(DeviceKind kind);

struct DeviceInfo {
  std::string backend;  // "sim", "gphoto2", "aravis", "openni2"
  std::string id;       // unique within the backend, stable across enumerations: what Open takes
  DeviceKind kind = DeviceKind::kStillCamera;
  std::string model;
  std::string serial;
  std::string address;                         // port, URI or network address, as the backend names it
  std::map<std::string, std::string> details;  // backend-specific, shown by `relume devices`

  // "backend:id", the form users type on the command line.
  std::string FullId() const { return backend + ":" + id; }
};

}  // namespace relume::drivers
