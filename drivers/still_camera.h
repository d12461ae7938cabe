// A camera that takes single frames on request with controlled exposure: a DSLR (libgphoto2),
// a machine-vision camera (Aravis) or the simulator. Small on purpose; retries, reconnects and
// warm-up dropping are wrappers (drivers/retry.h), not flags in here.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "drivers/device_info.h"
#include "drivers/frame.h"

namespace relume::drivers {

// How exposure can be controlled.
enum class ExposureControl {
  kShutterList,  // a discrete list of shutter speeds (DSLR)
  kContinuous,   // any exposure time within a range (machine vision)
  kEvOnly,       // only EV compensation relative to the camera's own metering (semi-automatic);
                 // absolute exposure times are unknown, only 2^EV ratios
};
const char* ToString(ExposureControl control);

struct ExposureCapabilities {
  ExposureControl control = ExposureControl::kShutterList;
  std::vector<double> shutter_speeds_s;  // kShutterList: ascending
  double min_exposure_time_s = 0.0;      // kContinuous
  double max_exposure_time_s = 0.0;
  std::vector<double> ev_steps;     // kEvOnly: the EV compensation values offered, ascending
  std::vector<double> apertures_f;  // empty when the aperture cannot be set
  std::vector<double> iso_values;   // empty when ISO cannot be set
  double min_gain_db = 0.0;         // min == max when gain cannot be set
  double max_gain_db = 0.0;
};

// What to change before the next capture; unset fields stay as they are.
struct ExposureSettings {
  std::optional<double> exposure_time_s;  // kShutterList (must be one of the list) or kContinuous
  std::optional<double> ev_compensation;  // kEvOnly
  std::optional<double> aperture_f;
  std::optional<double> iso;
  std::optional<double> gain_db;
};

class StillCamera {
 public:
  virtual ~StillCamera() = default;
  virtual const DeviceInfo& info() const = 0;
  virtual ExposureCapabilities capabilities() const = 0;
  // Applies settings, validated against capabilities(): a value the camera does not offer
  // throws DeviceError(kUnsupportedSetting) and changes nothing.
  virtual void Apply(const ExposureSettings& settings) = 0;
  // Takes one frame with the current settings. Throws DeviceError on failure.
  virtual StillFrame Capture() = 0;
};

}  // namespace relume::drivers
