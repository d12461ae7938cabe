#include "sim/devices/exposure_modes.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "drivers/device_error.h"

namespace relume::sim {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::ExposureCapabilities;
using drivers::ExposureControl;

drivers::ExposureCapabilities DslrCapabilities() {
  ExposureCapabilities caps;
  caps.control = ExposureControl::kShutterList;
  // The marked 1/3-stop series (the values cameras show and accept), fast to slow.
  for (double denominator : {4000, 3200, 2500, 2000, 1600, 1250, 1000, 800, 640, 500, 400, 320, 250, 200, 160, 125,
                             100,  80,   60,   50,   40,   30,   25,   20,  15,  13,  10,  8,   6,   5,   4}) {
    caps.shutter_speeds_s.push_back(1.0 / denominator);
  }
  for (double seconds : {0.3, 0.4, 0.5, 0.6, 0.8,  1.0,  1.3,  1.6,  2.0,  2.5, 3.2,
                         4.0, 5.0, 6.0, 8.0, 10.0, 13.0, 15.0, 20.0, 25.0, 30.0}) {
    caps.shutter_speeds_s.push_back(seconds);
  }
  caps.apertures_f = {2.8, 3.2,  3.5,  4.0,  4.5,  5.0,  5.6,  6.3,  7.1, 8.0,
                      9.0, 10.0, 11.0, 13.0, 14.0, 16.0, 18.0, 20.0, 22.0};
  caps.iso_values = {100, 200, 400, 800, 1600, 3200, 6400};
  return caps;
}

drivers::ExposureCapabilities MachineVisionCapabilities() {
  ExposureCapabilities caps;
  caps.control = ExposureControl::kContinuous;
  caps.min_exposure_time_s = 10e-6;
  caps.max_exposure_time_s = 10.0;
  caps.min_gain_db = 0.0;
  caps.max_gain_db = 24.0;
  return caps;
}

drivers::ExposureCapabilities EvOnlyCapabilities() {
  ExposureCapabilities caps;
  caps.control = ExposureControl::kEvOnly;
  for (int k = -15; k <= 15; ++k) caps.ev_steps.push_back(k / 3.0);
  return caps;
}

drivers::ExposureCapabilities DefaultCapabilities(drivers::ExposureControl control) {
  switch (control) {
    case ExposureControl::kShutterList: return DslrCapabilities();
    case ExposureControl::kContinuous: return MachineVisionCapabilities();
    case ExposureControl::kEvOnly: return EvOnlyCapabilities();
  }
  return DslrCapabilities();
}

namespace {

bool InList(const std::vector<double>& list, double value, double relative, double absolute) {
  return std::any_of(list.begin(), list.end(), [&](double offered) {
    return std::abs(offered - value) <= relative * std::abs(offered) + absolute;
  });
}

std::string Describe(const std::vector<double>& list) {
  if (list.empty()) return "none (not settable on this camera)";
  std::ostringstream text;
  text << list.front() << " .. " << list.back() << " (" << list.size() << " values)";
  return text.str();
}

[[noreturn]] void Unsupported(const std::string& device_id, const std::string& what) {
  throw DeviceError(DeviceErrorKind::kUnsupportedSetting, device_id, what);
}

}  // namespace

void ValidateSettings(const ExposureCapabilities& caps, const drivers::ExposureSettings& settings,
                      const std::string& device_id) {
  if (settings.exposure_time_s) {
    const double t = *settings.exposure_time_s;
    switch (caps.control) {
      case ExposureControl::kShutterList:
        if (!InList(caps.shutter_speeds_s, t, 1e-3, 0.0))
          Unsupported(device_id, "exposure_time_s " + std::to_string(t) + " is not a shutter speed of this camera; " +
                                     "offered: " + Describe(caps.shutter_speeds_s));
        break;
      case ExposureControl::kContinuous:
        if (!(t >= caps.min_exposure_time_s && t <= caps.max_exposure_time_s))
          Unsupported(device_id, "exposure_time_s " + std::to_string(t) + " is outside [" +
                                     std::to_string(caps.min_exposure_time_s) + ", " +
                                     std::to_string(caps.max_exposure_time_s) + "] s");
        break;
      case ExposureControl::kEvOnly:
        Unsupported(device_id, "this camera meters its own exposure time; set ev_compensation instead");
    }
  }
  if (settings.ev_compensation) {
    if (caps.control != ExposureControl::kEvOnly)
      Unsupported(device_id, "EV compensation is only offered by EV-only cameras; set exposure_time_s");
    if (!InList(caps.ev_steps, *settings.ev_compensation, 0.0, 1e-6))
      Unsupported(device_id, "ev_compensation " + std::to_string(*settings.ev_compensation) +
                                 " is not offered; offered: " + Describe(caps.ev_steps));
  }
  if (settings.aperture_f && !InList(caps.apertures_f, *settings.aperture_f, 1e-3, 0.0))
    Unsupported(device_id, "aperture f/" + std::to_string(*settings.aperture_f) +
                               " is not offered; offered: " + Describe(caps.apertures_f));
  if (settings.iso && !InList(caps.iso_values, *settings.iso, 1e-3, 0.0))
    Unsupported(device_id,
                "ISO " + std::to_string(*settings.iso) + " is not offered; offered: " + Describe(caps.iso_values));
  if (settings.gain_db) {
    const double g = *settings.gain_db;
    if (!(g >= caps.min_gain_db - 1e-9 && g <= caps.max_gain_db + 1e-9))
      Unsupported(device_id, "gain_db " + std::to_string(g) + " is outside [" + std::to_string(caps.min_gain_db) +
                                 ", " + std::to_string(caps.max_gain_db) + "] dB");
  }
}

bool MeteringOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(target_fraction > 0.0 && target_fraction < 1.0)) return fail("metering target_fraction must be in (0, 1)");
  if (!(min_exposure_time_s > 0.0 && max_exposure_time_s >= min_exposure_time_s))
    return fail("metering needs 0 < min_exposure_time_s <= max_exposure_time_s");
  if (max_samples < 1) return fail("metering max_samples must be positive");
  return true;
}

MeteringResult MeterExposure(const RadianceImage& radiance, const PinholeIntrinsics& intrinsics,
                             const ExposureParams& exposure, const CameraModelOptions& model,
                             const MeteringOptions& metering) {
  ThrowIfInvalid(metering, "metering options");
  ThrowIfInvalid(model, "camera model options");
  RELUME_CHECK(radiance.pixels.type() == CV_32FC3);
  ExposureParams per_second = exposure;
  per_second.exposure_time_s = 1.0;
  const double gain = per_second.Gain(model);
  const long pixels = static_cast<long>(radiance.width()) * radiance.height();
  const int stride =
      std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(pixels) / metering.max_samples))));
  std::vector<double> signal;  // fraction of white per second of exposure
  for (int y = stride / 2; y < radiance.height(); y += stride) {
    for (int x = stride / 2; x < radiance.width(); x += stride) {
      const cv::Vec3f& rgb = radiance.pixels.at<cv::Vec3f>(y, x);
      double luminance = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];  // Rec. 709 weights
      if (!std::isfinite(luminance) || luminance < 0.0) luminance = 0.0;
      signal.push_back(luminance * ElectronsPerRadiance(intrinsics, x + 0.5, y + 0.5, per_second, model) * gain /
                       model.full_well_e);
    }
  }
  double statistic = 0.0;
  if (!signal.empty()) {
    if (metering.statistic == MeteringOptions::Statistic::kMedian) {
      auto middle = signal.begin() + static_cast<long>(signal.size() / 2);
      std::nth_element(signal.begin(), middle, signal.end());
      statistic = *middle;
    } else {
      for (double s : signal) statistic += s;
      statistic /= static_cast<double>(signal.size());
    }
  }
  MeteringResult result;
  const double wanted = statistic > 0.0 ? metering.target_fraction / statistic : metering.max_exposure_time_s * 2;
  result.exposure_time_s = std::clamp(wanted, metering.min_exposure_time_s, metering.max_exposure_time_s);
  result.clamped = result.exposure_time_s != wanted;
  return result;
}

}  // namespace relume::sim
