// Errors of an estimate against the truth, defined once for the pipelines, the tests and
// `relume bench` (issue 21: five definitions had grown apart; the IRM bench and the IRM pipeline
// drew the shadow/penumbra line at different sun fractions and scaled differently).
//
// Two error measures, both dimensionless:
//   per-sample relative RMS  sqrt(mean over samples and channels of ((a e - t) / t)^2)
//     every pixel counts alike, dark or bright: the measure for relit radiance, where a
//     shadow's error matters as much as a lit wall's. Needs t > 0.
//   signal-relative RMS      sqrt(sum |a e - t|^2 / sum |t|^2)
//     bright pixels weigh more: the measure for fits of light (irradiance, SH relighting).
// `a` is 1 (absolute comparison) or, for relative radiance (a camera without radiometric
// calibration gives radiance up to one unknown scale), the least-squares scale of the measure
// used: sum q / sum q^2 with q = e / t for the per-sample measure.
// Samples compared: the mask's non-zero pixels where every channel of e and t is finite (and
// t > 0 for the per-sample measure).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

namespace relume::metrics {

enum class Scale {
  kAbsolute,  // a = 1
  kFitted,    // a = the least-squares scale of the measure (relative radiance)
};

// Where a pixel is in sunlight, from the truth's fraction of the sun's disk visible at two
// times (IRM relighting: the source's and the target's sun). Lit: >= 0.99 at both; penumbra:
// strictly between 0.01 and 0.99 at either; shadow: the rest (including NaN, an attached
// shadow: the sun behind the surface).
enum class SunRegion { kLit, kShadow, kPenumbra };
SunRegion ClassifySunRegion(float source_fraction, float target_fraction);

// Per-sample relative RMS of `estimate` against `truth` (CV_32FC3), overall and per SunRegion.
struct SunRegionErrors {
  double scale = 0.0;  // a; 0 when nothing was compared
  double all = 0.0, lit = 0.0, shadow = 0.0, penumbra = 0.0;
  std::int64_t lit_pixels = 0, shadow_pixels = 0, penumbra_pixels = 0;
};
// `source_sun`, `target_sun`: CV_32FC1 sun fractions; `use`: CV_8UC1 mask. `error_image`
// (optional): CV_8UC3, brightness the pixel's error (white at 10 %), hue its region (grey lit,
// blue shadow, red penumbra).
SunRegionErrors CompareSunRegions(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& source_sun,
                                  const cv::Mat& target_sun, const cv::Mat& use, Scale scale,
                                  cv::Mat* error_image = nullptr);

// Signal-relative RMS of `estimate` against `truth` (CV_32FC3) over `mask` (CV_8UC1; empty:
// every pixel). 0 samples: NaN.
struct SignalError {
  double scale = 1.0;
  double relative_rms = 0.0;
  std::int64_t pixels = 0;
};
SignalError SignalRelativeRms(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask, Scale scale);

}  // namespace relume::metrics
