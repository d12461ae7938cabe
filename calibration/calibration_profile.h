// A camera's radiometric calibration: inverse response (optional), neutral gain and colour
// matrix, saved as JSON and applied to camera frames or merged radiance.
//
// Conventions:
//  - Apply(frame, t): X = response(z) (or (z - black) / (white - black) for sensor-linear
//    frames without a response) per channel; v = X / t; then gain, then CCM. The result is
//    linear sRGB (D65) in chart-reflectance units under the calibration light (times 1/t of the
//    chart's exposure when t differs), RadianceUnit::kRelative.
//  - `gain_input` records what the gain was fitted on: "radiance" (X / t of a frame, or a
//    merged image) or "normalized_code" (codes / white level of a non-linearised frame; then
//    the gain is also the linearisation, Troccoli & Allen). Apply() feeds the gain the same.
//  - JSON: {"format": "relume-calibration-profile", "version": 1, "camera", "gain_input",
//    "response": null | {"levels", "sensor_linear", "inverse": [[...] per channel]},
//    "gain": [{"x": [...], "y": [...]} x3], "ccm": [[3] x3], "fit": {...}}.
#pragma once

#include <optional>
#include <string>

#include "calibration/colorchecker_fit.h"
#include "calibration/response.h"
#include "core/image.h"

namespace relume::calibration {

struct CalibrationProfile {
  std::string camera;
  std::string gain_input = "radiance";  // or "normalized_code"
  std::optional<CameraResponse> response;
  PiecewiseLinearGain gain;
  Eigen::Matrix3d ccm = Eigen::Matrix3d::Identity();
  ColorFitSummary fit;  // how the chart fit ended (informative)

  bool IsValid(std::string* why) const;
};

void SaveProfile(const CalibrationProfile& profile, const std::string& path);  // throws IoError
// Throws IoError (unreadable) or ConfigError naming the key that is missing or malformed.
CalibrationProfile LoadProfile(const std::string& path);
// The same JSON as text (sessions keep profiles in their calibrations table). `path` names the
// origin in error messages (a file, or "session DIR calibration N").
std::string ProfileToJson(const CalibrationProfile& profile);
CalibrationProfile ProfileFromJson(const std::string& text, const std::string& path);

// Linearises and colour-corrects one 8/16-bit RGB frame taken with exposure_time_s.
RadianceImage ApplyProfile(const CalibrationProfile& profile, const CameraImage& frame, double exposure_time_s);
// Gain and CCM on a radiance image (merged HDR, already linear). NaN stays NaN.
RadianceImage ApplyProfile(const CalibrationProfile& profile, const RadianceImage& radiance);

}  // namespace relume::calibration
