// Exposure bracket planning: the fewest exposures that cover a scene's dynamic range with
// usable signal everywhere, after Stumpfel et al. 2004 ("Direct HDR Capture of the Sun and
// Sky": 17 stops in seven exposures, range adjusted adaptively).
//
// Convention: the planner works with a pixel's *linear signal* s in [0, 1] of the sensor's
// full scale. Scene radiance is proportional to s / e, where e is the frame's relative
// exposure (exposure time x gain, or 2^EV on EV-only cameras). A pixel is usable in a frame
// when min_signal_fraction <= s <= saturation_fraction. Camera-encoded (JPEG-like) frames
// are linearised for metering with a known inverse response, or sRGB's when none is known:
// metering only needs to be right to a fraction of a stop.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "drivers/still_camera.h"

namespace relume::capture {

struct BracketPlannerOptions {
  double saturation_fraction = 0.90;     // highest usable linear signal (headroom below clipping)
  double min_signal_fraction = 0.04;     // lowest usable linear signal in the darkest regions
  double overlap_stops = 1.0;            // overlap of neighbouring frames' usable ranges
  double dark_percentile = 0.02;         // "darkest region of interest" of the metering frame
  double bright_percentile = 0.999;      // "brightest region of interest"
  double clipped_share = 0.001;          // more pixels than this at clipping: the range is unknown
  double clipped_extension_stops = 3.0;  // how much darker to plan when the metering frame clips
  int max_exposures = 9;
  // Steps between exposures alternate longer and shorter, 1 + d and 1 - d times their mean,
  // with d up to this fraction, within the coverage the overlap allows (one exposure more when
  // there is room for less than half of it). Why: from frames with one exposure ratio r
  // between neighbours, a camera's response can be recovered only up to a factor periodic in
  // log radiance with period log r (docs/calibration.md), so encoded brackets 2-4 stops apart
  // pin the curve down badly; two different ratios remove that freedom (5 frames over 8 stops,
  // a tabulated response: 2.5 % radiance error with equal steps, 1.0 % with unequal ones).
  // 0: equal steps.
  double unequal_steps = 0.2;
  bool IsValid(std::string* why) const;
};

// What a metering frame says about the scene.
struct MeteringStats {
  double relative_exposure = 1.0;  // e of the metering frame
  double dark_signal = 0.0;        // linear signal at dark_percentile (of each pixel's max channel)
  double bright_signal = 0.0;      // at bright_percentile
  double clipped_share = 0.0;      // share of pixels with a clipped channel
  double black_share = 0.0;        // share of pixels with no signal at all
};

// Linearises a metering frame (per-channel max) and measures it. `inverse_response` maps an
// encoded value in [0, 1] to linear signal in [0, 1]; empty = sensor-linear frames use
// (v - black) / (white - black), camera-encoded frames use the sRGB curve. An optional mask
// (CV_8UC1, non-zero = of interest) limits the statistics to the pixels of interest.
MeteringStats MeasureMeteringFrame(const CameraImage& frame, double relative_exposure,
                                   const BracketPlannerOptions& options,
                                   const std::function<double(double)>& inverse_response = {},
                                   const cv::Mat& mask = cv::Mat());

struct PlannedExposure {
  double relative_exposure = 1.0;         // relative to the metering frame's exposure
  std::optional<double> exposure_time_s;  // shutter-list and continuous cameras
  std::optional<double> ev_compensation;  // EV-only cameras
  drivers::ExposureSettings Settings() const;
};

struct BracketPlan {
  std::vector<PlannedExposure> exposures;  // shortest (darkest) first
  double scene_range_stops = 0.0;          // bright / dark radiance, in stops
  bool range_known = true;                 // false when the metering frame clipped
  bool covers_range = true;                // false when the camera's limits or max_exposures cut it
  std::string reason;                      // why this plan (one exposure, clipped, limited ...)
};

// Plans a bracket for a camera. `metering_exposure_time_s` is the metering frame's exposure
// time (ignored for EV-only cameras, where `metering_ev` is its EV compensation).
BracketPlan PlanBracket(const MeteringStats& metering, const drivers::ExposureCapabilities& caps,
                        double metering_exposure_time_s, double metering_ev, const BracketPlannerOptions& options);

// A bracket for a camera whose metering frame gave no pixels relume can read (a camera raw
// file it cannot decode): the usual spacing over `stops_each_side` stops on either side of the
// metering exposure (so a frame's usable range reaches that far), snapped to the camera.
// range_known is false and the reason says the scene was not metered.
BracketPlan PlanUnmeteredBracket(const drivers::ExposureCapabilities& caps, double metering_exposure_time_s,
                                 double metering_ev, const BracketPlannerOptions& options,
                                 double stops_each_side = 4.0);

// Adaptive range: after capturing the plan's darkest frame, if it still clips, returns one
// more, darker exposure (or nothing when it does not clip or the camera has none darker).
std::optional<PlannedExposure> ExtendDarker(const MeteringStats& darkest_frame, const PlannedExposure& darkest,
                                            const drivers::ExposureCapabilities& caps, double metering_exposure_time_s,
                                            double metering_ev, const BracketPlannerOptions& options);

}  // namespace relume::capture
