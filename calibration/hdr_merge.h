// Merging an exposure bracket into one linear radiance image (Debevec & Malik 1997, eq. 6):
//   L(p) = sum_j w(z_pj) X(z_pj) / t_j  /  sum_j w(z_pj)     per channel,
// where X is the inverse response (response.h) and w a hat weight that is zero for black
// and saturated codes, so clipped samples never contribute.
//
// Conventions:
//  - Output: RadianceImage, CV_32FC3 (or CV_32FC1 for mono/Bayer input), relative units:
//    X(z) / exposure_time_s, i.e. radiance up to one scale per channel.
//  - contributors: CV_16UC1, bit j set when frame j (in the order given) had non-zero weight
//    in at least one channel of the pixel. At most 16 frames.
//  - status: CV_8UC1 per pixel, HdrPixelStatus. Where no frame exposes a channel well the
//    value is still finite: saturated everywhere -> the shortest frame's value (a lower bound);
//    black everywhere -> the longest frame's value (an upper bound, often 0). Never NaN.
//  - Works in one pass per row over all frames with per-frame lookup tables
//    (X(z)/t_j * w(z) and w(z)), rows split across threads (core/parallel.h).
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "calibration/response.h"
#include "core/image.h"

namespace relume::calibration {

enum HdrPixelStatus : std::uint8_t {
  kHdrGood = 0,                 // every channel had at least one well-exposed sample
  kHdrSaturatedLowerBound = 1,  // some channel saturated in every frame
  kHdrBlackUpperBound = 2,      // some channel black in every frame
  // Not from a merge: no sample at all, where a frame undistorted onto its pinhole camera had
  // nothing (calibration/undistort.h); the radiance there is NaN.
  kHdrNoSample = 4,
};

struct HdrMergeOptions {
  // Codes within these margins of black_level / white_level get zero weight. For 8-bit
  // camera-encoded frames the margins are in codes; for sensor-linear frames in counts.
  int black_margin = 2;
  int saturation_margin = 2;
  // Weight hat times exposure time (favours longer exposures, whose relative noise is lower);
  // false = the plain hat of Debevec & Malik.
  bool weight_by_exposure = true;
  int threads = 0;  // 0 = std::thread::hardware_concurrency()

  bool IsValid(std::string* why) const;
};

struct HdrMergeSummary {
  int frames = 0;
  long long pixels = 0;
  long long pixels_saturated_everywhere = 0;  // lower bounds (status kHdrSaturatedLowerBound)
  long long pixels_black_everywhere = 0;      // upper bounds (status kHdrBlackUpperBound)
  int threads_used = 0;
  std::string reason;  // notes, e.g. "37 pixels saturated in every frame"
  std::string BriefReport() const;
};

struct HdrMergeResult {
  RadianceImage radiance;
  cv::Mat contributors;  // CV_16UC1 bit mask
  cv::Mat status;        // CV_8UC1 HdrPixelStatus
  HdrMergeSummary summary;
};

// Merges frames (any order, duplicates allowed, one frame allowed) taken with the given
// exposure times. `response` must have the frames' channel count and 2^bits levels
// (8-bit: a recovered response; 16-bit sensor-linear: CameraResponse::Linear).
// Throws InvalidArgumentError for inconsistent input.
HdrMergeResult MergeHdr(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s,
                        const CameraResponse& response, const HdrMergeOptions& options = {});

// The response to use for sensor-linear frames (raw): linear between black and white level.
CameraResponse SensorLinearResponse(const CameraImage& frame);

}  // namespace relume::calibration
