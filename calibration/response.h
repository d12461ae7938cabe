// Camera response recovery: from a bracket of frames of a static scene taken with known
// exposures, the inverse response per channel, i.e. what relative exposure (radiance times
// exposure time) each code value stands for.
//
// Conventions:
//  - Frames are CameraImage with kCameraResponse encoding, 8 bits per sample, RGB or mono
//    (a sensor-linear frame needs no recovery: use CameraResponse::Linear).
//  - The inverse response of channel c maps a code value z in [0, levels) to a relative
//    exposure X = f_c^{-1}(z), linear in radiance * exposure_time_s. Its scale is fixed by
//    X(mid code) = 1 for every channel, so channels are NOT white balanced by the response:
//    colour balance belongs to the chart fit (colorchecker_fit.h).
//  - Radiance from one frame: L = X(z) / exposure_time_s (relative units).
//  - Weights: the hat function w(z) = min(z - z_min, z_max - z) over the code range, zero at
//    and beyond the black and saturated ends.
//  - EV-only cameras (Loscos et al.): exposure EV e means a relative exposure time 2^e; the
//    true ratios differ (discrete shutter steps, metering), so per-frame scale factors are
//    then refined by least squares over pixels well exposed in two frames
//    (RefineExposureScales). FitScaleFactor is the same least-squares scale, usable for any
//    pair of radiance images that should agree (e.g. radiance consistency across lightings).
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/scale_fit.h"

namespace relume::calibration {

// The inverse response per channel, tabulated for every code value.
struct CameraResponse {
  int levels = 256;
  // inverse[c][z] = relative exposure for code z in channel c; non-decreasing; >= 0.
  std::vector<std::vector<double>> inverse;
  bool sensor_linear = false;  // true for CameraResponse::Linear

  int channels() const { return static_cast<int>(inverse.size()); }
  // A linear response for sensor counts: X(z) = max(z - black_level, 0) / (white - black).
  static CameraResponse Linear(int channels, int levels, int black_level, int white_level);
  bool IsValid(std::string* why) const;
};

enum class ResponseMethod { kDebevec, kRobertson };
const char* ToString(ResponseMethod method);
ResponseMethod ResponseMethodFromString(const std::string& name);  // throws InvalidArgumentError

// What Debevec's smoothness term penalises, at code z of g(z) = ln X(z). Where the bracket's
// exposures are far apart the data fix g only up to a function periodic in ln X (period: the
// log exposure ratio), and the term chooses among those curves; each choice is exact for the
// curves it does not penalise at all (its null space).
enum class ResponseSmoothness {
  // g''(z) (Debevec & Malik 1997). Null space g = a + b z: X grows exponentially with the code.
  kCode,
  // z^-2 d2g/d(ln z)^2 = g''(z) + g'(z) / z: the same weight per code as kCode, but its null
  // space g = a + b ln z is every power law X = c z^b, i.e. gamma encodings and linear codes
  // (b = 1). The default: on sparse brackets it is better, or equal within noise, for every
  // test curve but one S-shaped tone curve (docs/calibration.md).
  kLogCode,
};
const char* ToString(ResponseSmoothness smoothness);
ResponseSmoothness ResponseSmoothnessFromString(const std::string& name);  // throws InvalidArgumentError

struct ResponseOptions {
  ResponseMethod method = ResponseMethod::kDebevec;
  // Pixels sampled from the image (each gives one equation per frame). Spread over the
  // intensity range of the reference frame and over the image; flat regions preferred.
  int sample_count = 300;
  // Debevec: weight of the second-derivative smoothness term (relative to hat weights in
  // [0, 1]). Larger = smoother curve. 60 suits kLogCode; kCode was tuned at 40 (Debevec's
  // earlier default: smoothness kCode with lambda 40).
  double lambda = 60.0;
  ResponseSmoothness smoothness = ResponseSmoothness::kLogCode;
  // Debevec: the curve is also solved with the other smoothness term; where the two differ by
  // more than this (largest relative difference of X over well-exposed codes), the data do not
  // determine the curve and the summary is flagged low_confidence.
  double max_prior_disagreement = 0.02;
  // Robertson: stop when the largest relative change of the curve is below tolerance.
  int robertson_max_iterations = 50;
  double robertson_tolerance = 1e-4;
  // Codes at or below black_margin and at or above levels-1-saturation_margin count as black /
  // saturated (zero weight).
  int black_margin = 2;
  int saturation_margin = 2;
  std::uint64_t seed = 1;  // sample selection is deterministic for a given seed

  bool IsValid(std::string* why) const;
};

struct ResponseSummary {
  ResponseMethod method = ResponseMethod::kDebevec;
  bool usable = false;     // false: the response must not be used (reason says why)
  bool converged = false;  // Robertson: tolerance reached; Debevec: solved
  int iterations = 0;      // Robertson iterations; 1 for Debevec
  double residual = 0.0;   // RMS of the weighted data equations (log or linear domain)
  double condition = 0.0;  // condition number of the (normal) system, worst channel
  int samples_used = 0;    // pixels contributing equations
  int frames_used = 0;
  int monotonic_fixes = 0;  // codes where the curve had to be made non-decreasing
  // Debevec only: largest relative difference of X(z), over codes with hat weight >= 0.15 and
  // all channels, between the curves recovered with the two ResponseSmoothness terms. It
  // measures how much of the curve rests on the smoothness prior rather than on the data (two
  // curves d apart cannot both be within d/2 of the truth); it is not the chosen curve's error,
  // and curves with kinks fool both terms alike. Empty for Robertson.
  std::optional<double> prior_disagreement;
  // The curve is usable but poorly determined (prior disagreement above the options' limit, or
  // few informative samples); reason says why.
  bool low_confidence = false;
  std::string reason;  // how it ended / warnings

  std::string BriefReport() const;
};

struct ResponseResult {
  CameraResponse response;
  ResponseSummary summary;
};

// A hat weight over [black_margin + 1, levels - 2 - saturation_margin], in [0, 1].
std::vector<double> HatWeights(int levels, int black_margin, int saturation_margin);

// Recovers the inverse response. Throws InvalidArgumentError for unusable input (fewer than
// two frames, sizes or types differ, exposures not positive, not 8-bit); duplicated exposures
// and any order are accepted (frames are sorted internally). A bracket whose frames are
// saturated everywhere, or where too few samples are informative, gives usable=false.
ResponseResult RecoverResponse(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s,
                               const ResponseOptions& options = {});

// Relative exposure times for EV values (EV 0 -> reference_time_s): t = reference * 2^EV.
std::vector<double> ExposureTimesFromEv(const std::vector<double>& ev, double reference_time_s = 1.0);

// Least-squares scale a minimising sum over mask of |a * values - reference|^2 (Loscos et al.,
// eq. 3), through core's ScaleFitter (core/scale_fit.h, the one implementation the radiosity
// layer shares): values/reference CV_32F with equal channels; mask CV_8UC1 (non-zero = use), or
// empty for all pixels; only channels where both are finite and > 0 count; not usable with
// fewer than 10 such samples.
using relume::ScaleFit;
ScaleFit FitScaleFactor(const cv::Mat& values, const cv::Mat& reference, const cv::Mat& mask = cv::Mat());

// Refines exposure times (EV-only cameras, or untrusted metadata): each frame's exposure is
// scaled so its linearised image agrees with its neighbour's over pixels well exposed in
// both, chained from the frame closest to the middle. Returns the refined times (same order
// as given); frames without enough common pixels keep their nominal time (and `notes` says so).
std::vector<double> RefineExposureScales(const std::vector<CameraImage>& frames,
                                         const std::vector<double>& nominal_exposure_times_s,
                                         const CameraResponse& response, const ResponseOptions& options,
                                         std::string* notes = nullptr);

// EV bracket in one call: EV -> 2^EV, recover, refine the scales, recover again with them.
// Exposure ratios and the response are jointly determined only up to a common exponent, so
// the refined times keep the nominal EV span between the shortest and the longest frame; what
// the refinement recovers is each frame's deviation from the EV ladder.
struct EvCalibration {
  ResponseResult result;
  std::vector<double> exposure_times_s;  // refined relative times (EV 0 = 1 before refinement)
};
EvCalibration RecoverResponseFromEv(const std::vector<CameraImage>& frames, const std::vector<double>& ev,
                                    const ResponseOptions& options = {});

}  // namespace relume::calibration
