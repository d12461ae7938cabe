// Typed device errors. Every backend (sim, gphoto2, aravis, openni2, usb) maps its library's
// failures onto these, so callers can tell "try again" from "plug the cable back in" from
// "that setting does not exist", whatever the device.
#pragma once

#include <string>

#include "core/error.h"

namespace relume::drivers {

enum class DeviceErrorKind {
  kDisconnected,        // the device went away (cable, power); reopening may help
  kTimeout,             // no answer in time; retrying may help
  kBusy,                // the device is busy (e.g. PTP "device busy"); retry with backoff
  kIo,                  // a transfer failed; retrying may help
  kCorruptFrame,        // a frame arrived damaged or truncated; the next one may be fine
  kUnsupportedSetting,  // the device does not offer that value; retrying will not help
  kNotFound,            // no such device
  kAccessDenied,        // present but cannot be opened (permissions, claimed by another process)
};
const char* ToString(DeviceErrorKind kind);
// True for failures that a retry of the same call may cure (busy, timeout, I/O, corrupt frame).
bool IsRetryable(DeviceErrorKind kind);

class DeviceError : public Error {
 public:
  // The message reads "<device_id>: <kind>: <what>".
  DeviceError(DeviceErrorKind kind, std::string device_id, const std::string& what);
  DeviceErrorKind kind() const { return kind_; }
  const std::string& device_id() const { return device_id_; }
  bool retryable() const { return IsRetryable(kind_); }

 private:
  DeviceErrorKind kind_;
  std::string device_id_;
};

}  // namespace relume::drivers
