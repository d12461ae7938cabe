// The three ways a simulated still camera lets its exposure be controlled
// (drivers::ExposureControl), the settings each offers, validation of requested settings against
// them, and the light metering of semi-automatic (EV-only) cameras.
//
//  - kShutterList (DSLR-like): the marked shutter speeds 1/4000 s .. 30 s in 1/3 stops, apertures
//    f/2.8 .. f/22 in 1/3 stops, ISO 100 .. 6400 in whole stops; no analogue gain setting.
//  - kContinuous (machine vision): any exposure time in [10 us, 10 s] and gain in [0, 24] dB;
//    fixed aperture and ISO.
//  - kEvOnly (semi-automatic): the camera meters the scene and picks its own exposure time;
//    only EV compensation in -5 .. +5 EV, 1/3 EV steps, can be set. The exposure time chosen
//    is not reported (ExposureRecord::exposure_time_s = NaN): only the 2^EV ratio is known.
#pragma once

#include <string>

#include "drivers/still_camera.h"
#include "sim/devices/camera_model.h"

namespace relume::sim {

drivers::ExposureCapabilities DslrCapabilities();
drivers::ExposureCapabilities MachineVisionCapabilities();
drivers::ExposureCapabilities EvOnlyCapabilities();
drivers::ExposureCapabilities DefaultCapabilities(drivers::ExposureControl control);

// Throws DeviceError(kUnsupportedSetting) naming the first requested value the capabilities do
// not offer, and what is offered instead. Listed values match within 0.1 % (nominal marks).
void ValidateSettings(const drivers::ExposureCapabilities& capabilities, const drivers::ExposureSettings& settings,
                      const std::string& device_id);

// The in-camera meter of an EV-only camera: picks the exposure time at which the chosen
// statistic of the scene's luminance signal reaches target_fraction of the camera's white.
struct MeteringOptions {
  enum class Statistic { kMedian, kMean };
  Statistic statistic = Statistic::kMedian;
  double target_fraction = 0.18;  // mid-grey
  double min_exposure_time_s = 1.0 / 4000;
  double max_exposure_time_s = 30.0;
  int max_samples = 65536;  // pixels looked at (a regular subsample of large images)
  bool IsValid(std::string* why) const;
};

struct MeteringResult {
  double exposure_time_s = 0.0;
  bool clamped = false;  // the scene was too dark or too bright for the meter's range
};

// `exposure` supplies aperture, ISO and gain; its exposure time is ignored. A black scene
// meters to the longest time (clamped = true).
MeteringResult MeterExposure(const RadianceImage& radiance, const PinholeIntrinsics& intrinsics,
                             const ExposureParams& exposure, const CameraModelOptions& model,
                             const MeteringOptions& metering);

}  // namespace relume::sim
