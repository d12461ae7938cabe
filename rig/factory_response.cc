#include "rig/factory_response.h"

#include <cmath>
#include <cstdio>

#include "sim/devices/camera_model.h"

namespace relume::rig {

std::optional<calibration::CalibrationProfile> FactoryColorResponse(const sim::SimDeviceSpec& spec, std::string* why) {
  const auto fail = [&](const std::string& reason) -> std::optional<calibration::CalibrationProfile> {
    if (why != nullptr) *why = reason;
    return std::nullopt;
  };
  if (spec.kind != drivers::DeviceKind::kRgbdSensor) return fail(spec.id + " is not an RGB-D sensor");
  const sim::CameraModelOptions& model = spec.rgbd.color_model;
  if (model.vignetting.model != sim::Vignetting::Model::kNone) {
    return fail(spec.id + "'s colour camera model has vignetting, which a response cannot carry");
  }
  // Codes of the encoded 8-bit stream, decoded as the camera model encodes them, at a 1 s exposure
  // and the sensor's aperture, ISO and gain; times ISO/100, which linearisation divides by.
  sim::ExposureParams exposure = spec.rgbd.color_exposure;
  exposure.exposure_time_s = 1.0;
  const PinholeIntrinsics& intrinsics = spec.camera.intrinsics;
  const double cx = intrinsics.cx, cy = intrinsics.cy;
  constexpr int kLevels = 256;
  std::vector<double> inverse(kLevels);
  for (int z = 0; z < kLevels - 1; ++z) {
    const double r = sim::RadianceFromEncodedValue(z, intrinsics, cx, cy, exposure, model);
    inverse[static_cast<std::size_t>(z)] = std::isfinite(r) ? r * exposure.iso / 100.0 : 0.0;
  }
  // Code 255 is saturated (the model returns NaN there); the merge never trusts it, and the curve
  // keeps the level below it so that it stays non-decreasing.
  inverse.back() = inverse[kLevels - 2];
  calibration::CameraResponse response;
  response.levels = kLevels;
  response.inverse.assign(3, inverse);
  std::string reason;
  if (!response.IsValid(&reason)) return fail(spec.id + "'s colour response: " + reason);
  calibration::CalibrationProfile profile;
  char text[160];
  std::snprintf(text, sizeof(text), "sim:%s colour camera, factory response (%s curve; f/%.3g, ISO %.4g, %.3g dB)",
                spec.id.c_str(), sim::ToString(model.response.shape), exposure.aperture_f, exposure.iso,
                exposure.gain_db);
  profile.camera = text;
  profile.response = std::move(response);
  return profile;
}

std::vector<capture::CalibrationRecord> FactoryResponseRecords(const RigConfig& rig, UtcTime created) {
  std::vector<capture::CalibrationRecord> records;
  for (const sim::SimDeviceSpec& spec : rig.devices) {
    const std::optional<calibration::CalibrationProfile> profile = FactoryColorResponse(spec);
    if (!profile) continue;
    capture::CalibrationRecord record;
    record.created_utc = created;
    record.kind = "response";
    record.device_id = "sim:" + spec.id;
    record.json = calibration::ProfileToJson(*profile);
    records.push_back(std::move(record));
  }
  return records;
}

}  // namespace relume::rig
