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

#include <array>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
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
  // A drawn curve per channel (RandomCurve, RandomResponse below): a mixture of the families
  // above with drawn parameters, a contrast (toe and shoulder) curve and smooth wiggles.
  kRandom,
};
const char* ToString(ResponseShape shape);

// One channel of a kRandom response: exposure x in [0, 1] -> code fraction, strictly
// increasing from 0 to 1 and smooth. Built in three steps:
//  1. a convex mixture of four strictly increasing curves from 0 to 1: a power law
//     x^(1/gamma); an sRGB/Rec.709-like curve (linear toe up to x = toe_break, then
//     (1 + a) x^p - a with a fixed by value and slope continuity); a film-like S curve
//     x^s / (x^s + m^s) normalised; a log curve ln(1 + k x) / ln(1 + k);
//  2. a contrast curve in code space, (1 - c) y + c y^2 (3 - 2 y) (toe and shoulder; c in [0, 1));
//  3. monotone wiggles y + sum_k a_k sin(k pi y) / (k pi), k = 1..4, with sum |a_k| < 1 (so the
//     derivative stays positive and the ends stay at 0 and 1).
struct RandomCurve {
  double w_power = 1.0, w_srgb = 0.0, w_s = 0.0, w_log = 0.0;  // mixture weights, sum 1
  double gamma = 2.2;                                          // power: x^(1/gamma)
  double srgb_power = 1.0 / 2.4, srgb_break = 0.0031308;       // sRGB-like: p and the toe's end
  double s_slope = 1.6, s_mid = 0.3;                           // S curve: s and m
  double log_k = 100.0;                                        // log curve: k
  double contrast = 0.0;                                       // contrast curve: c
  std::array<double, 4> wiggle{};                              // a_1..a_4
  double Forward(double x) const;                              // x in [0, 1]
};

// The forward response (exposure -> code fraction), and its inverse, per channel.
struct SyntheticResponse {
  ResponseShape shape = ResponseShape::kGamma;
  std::array<RandomCurve, 3> curves{};          // kRandom only: one curve per channel
  double Forward(int channel, double x) const;  // x clipped to [0, 1]; result in [0, 1]
  double Inverse(int channel, double y) const;  // y in [0, 1] -> x in [0, 1] (bisection)
};

// A kRandom response drawn from `seed` (std::mt19937_64's raw output only, so the same curves
// on every standard library). The camera draws one or two families with their parameters,
// a contrast and wiggle amplitudes; each channel then gets its own parameters around the
// camera's (gamma and slopes +-8 %, mixture weights and contrast jittered) and its own
// wiggles, so no two channels are the same curve.
SyntheticResponse RandomResponse(std::uint64_t seed);
// One line: the families with their weights and parameters ("lo to hi" over the channels),
// the contrast and the wiggle amplitude sum |a_k|; other shapes: their name.
std::string DescribeResponse(const SyntheticResponse& response);

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
