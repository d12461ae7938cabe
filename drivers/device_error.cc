#include "drivers/device_error.h"

namespace relume::drivers {

const char* ToString(DeviceErrorKind kind) {
  switch (kind) {
    case DeviceErrorKind::kDisconnected: return "disconnected";
    case DeviceErrorKind::kTimeout: return "timeout";
    case DeviceErrorKind::kBusy: return "busy";
    case DeviceErrorKind::kIo: return "i/o error";
    case DeviceErrorKind::kCorruptFrame: return "corrupt frame";
    case DeviceErrorKind::kUnsupportedSetting: return "unsupported setting";
    case DeviceErrorKind::kNotFound: return "not found";
    case DeviceErrorKind::kAccessDenied: return "access denied";
  }
  return "unknown";
}

bool IsRetryable(DeviceErrorKind kind) {
  return kind == DeviceErrorKind::kTimeout || kind == DeviceErrorKind::kBusy || kind == DeviceErrorKind::kIo ||
         kind == DeviceErrorKind::kCorruptFrame;
}

DeviceError::DeviceError(DeviceErrorKind kind, std::string device_id, const std::string& what)
    : Error(device_id + ": " + ToString(kind) + ": " + what), kind_(kind), device_id_(std::move(device_id)) {}

}  // namespace relume::drivers
