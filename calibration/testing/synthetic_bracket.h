// Synthetic exposure brackets for calibration tests and benchmarks: a wide-dynamic-range
// radiance image (the truth), a known camera response, and sensor noise added by a separate
// step with a fixed seed, so truth and noise never mix. Small on purpose: this is test data
// for relume_calibration only and is to be replaced by the simulated camera model of
// sim/devices/ once that exists.
//
// Conventions: radiance is linear RGB (relative units), CV_32FC3. The sensor sees
// X = radiance * exposure_time_s; the response maps X (clipped to [0, 1]) to a code fraction
// in [0, 1]; codes are 8-bit, rounded. Pixel (x, y) as in core/image.h.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "calibration/response.h"
#include "core/image.h"

namespace relume::calibration::testing {

enum class ResponseShape {
  kGamma,   // x^(1/2.2) per channel
  kSCurve,  // a film-like S curve, x^s / (x^s + m^s) normalised; a different s per channel
  kTable,   // a tabulated piecewise-linear curve with per-channel knots
  // Standard encodings, to check that a method generalises beyond the three shapes above
  // (each with a slightly different exponent or slope per channel, as real channels differ):
  kSrgb,         // IEC 61966-2-1: linear toe, then 1.055 x^(1/2.4) - 0.055
  kRec709,       // ITU-R BT.709 OETF: linear toe up to x = 0.018, then 1.099 x^0.45 - 0.099
  kSrgbSTone,    // sRGB followed by a mild S-shaped contrast curve (a camera's picture style)
  kLogEncoding,  // log10(1 + k x) / log10(1 + k), k ~ 100 (cinema-camera log curves)
};
const char* ToString(ResponseShape shape);

// The forward response (exposure -> code fraction), and its inverse, per channel.
struct SyntheticResponse {
  ResponseShape shape = ResponseShape::kGamma;
  double Forward(int channel, double x) const;  // x clipped to [0, 1]; result in [0, 1]
  double Inverse(int channel, double y) const;  // y in [0, 1] -> x in [0, 1] (bisection)
};

struct SceneOptions {
  int width = 320;
  int height = 240;
  double dynamic_range = 1e4;  // brightest / darkest radiance in the scene
  std::uint64_t seed = 7;
};
// Patches of random colour whose brightness spans the dynamic range log-uniformly, each with
// a smooth 2x gradient (so every patch covers a range of codes).
cv::Mat MakeHdrRadiance(const SceneOptions& options);

// Geometric exposure times around `middle_s`, `stops` EV apart, shortest first.
std::vector<double> BracketExposures(int count, double stops, double middle_s);
// The same span (count - 1) x stops, with steps alternating (1 + d) and (1 - d) times their
// mean, rescaled to the span, centred on middle_s as BracketExposures (relume's bracket
// planner spaces exposures so; capture/bracket_planner.h, unequal_steps).
std::vector<double> UnequalBracketExposures(int count, double stops, double middle_s, double d);

struct NoiseOptions {
  double shot_noise = 0.0;  // photon noise: stddev = sqrt(shot_noise * X), X in [0, 1]
  double read_noise = 0.0;  // stddev in units of X
  std::uint64_t seed = 11;
};

// Ideal sensor exposure X = radiance * t (no noise, no clipping), CV_32FC3.
cv::Mat IdealExposure(const cv::Mat& radiance, double exposure_time_s);
// Adds noise to an exposure image (a copy; the input is untouched).
cv::Mat AddSensorNoise(const cv::Mat& exposure, const NoiseOptions& noise, std::uint64_t frame_index);
// Clips, applies the response, quantises to 8 bits: a camera-encoded RGB CameraImage.
CameraImage EncodeFrame(const cv::Mat& exposure, const SyntheticResponse& response);

// The whole bracket: one frame per exposure time, noise seeded per frame.
std::vector<CameraImage> RenderBracket(const cv::Mat& radiance, const std::vector<double>& exposure_times_s,
                                       const SyntheticResponse& response, const NoiseOptions& noise);

// The true inverse response as relume tabulates it: X(z) = Inverse(z / 255), scaled so that
// X(128) = 1 like a recovered response.
CameraResponse TrueInverseResponse(const SyntheticResponse& response);

// CV_8UC1 mask of pixels that at least one frame exposes well: every channel's noise-free
// code in [low_code, high_code].
cv::Mat WellExposedMask(const cv::Mat& radiance, const std::vector<double>& exposure_times_s,
                        const SyntheticResponse& response, int low_code = 10, int high_code = 245);

// Error of a relative radiance estimate against the truth over a mask, after the best
// per-channel scale (the estimate is only defined up to one scale per channel before colour
// calibration): mean and 95th percentile of |a_c e - t| / t over pixels and channels.
struct RadianceError {
  double mean_relative = 0.0;
  double p95_relative = 0.0;
  int pixels = 0;
};
RadianceError CompareRadiance(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask);

}  // namespace relume::calibration::testing
