// Finding a 24-patch ColorChecker in an image and measuring its patches.
//
// Conventions:
//  - Chart grid coordinates (units of one patch pitch): the patch grid spans [0, 6] x [0, 4]
//    with the chart upright (dark skin at the top left, white at the bottom left); patch k
//    (reading order, core/color.h) is the cell (k % 6, k / 6).
//  - ChartLocation::corners are the image positions (pixel-centre convention of core/image.h:
//    continuous coordinates, pixel (x, y) covers [x, x+1)) of grid (0,0), (6,0), (6,4), (0,4):
//    the outer corners of the patch grid, top-left first, in the chart's own orientation.
//  - Three ways to locate it: OpenCV contrib's mcc detector, relume's own square-lattice
//    detector (fallback), or four corners given by the user. Detectors return the chart's
//    outline; the orientation (which corner is dark skin) is chosen by matching the patches'
//    brightness order and chromaticities to the reference (any monotonic response keeps both).
#pragma once

#include <array>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/image.h"

namespace relume::calibration {

enum class ChartDetector { kAuto, kMcc, kLattice };  // kAuto: mcc, then the lattice fallback
const char* ToString(ChartDetector detector);
ChartDetector ChartDetectorFromString(const std::string& name);

struct ChartDetectOptions {
  ChartDetector detector = ChartDetector::kAuto;
  int min_patch_side_px = 6;  // lattice: smaller squares are ignored
  bool IsValid(std::string* why) const;
};

struct ChartLocation {
  bool found = false;
  std::string method;  // "mcc", "lattice", "manual"
  std::array<cv::Point2f, 4> corners{};
  double orientation_score = 0.0;  // match of brightness order and chroma to the reference, <= 2
  std::string reason;              // why not found, or notes
};

// Detects the chart in an 8-bit RGB preview (camera output, or a tone-mapped radiance image).
ChartLocation DetectColorChecker(const cv::Mat& rgb8, const ColorCheckerReference& reference,
                                 const ChartDetectOptions& options = {});

// A location from four user-given points (any order around the chart, any start): they are
// ordered around their centre and the orientation is chosen like a detector's. Throws
// InvalidArgumentError unless there are exactly 4 finite, distinct, convex points.
ChartLocation ChartFromCorners(const std::vector<cv::Point2f>& points, const cv::Mat& rgb8,
                               const ColorCheckerReference& reference);

// What the patches are measured from: values linear or not (camera codes / white level, or
// merged radiance), and a mask of pixels that must not be used (clipped or black).
struct ChartImage {
  cv::Mat values;   // CV_32FC3
  cv::Mat clipped;  // CV_8UC1, 1 = saturated in some channel, 2 = black; empty = none
};
// From a camera image: values = (code - black) / (white - black); codes within `margin` of
// white are marked saturated, within `margin` of black marked black.
ChartImage ChartImageFromCamera(const CameraImage& image, int margin = 2);

enum class PatchStatus { kOk, kSaturated, kBlack, kNonUniform, kOutside };
const char* ToString(PatchStatus status);

struct PatchSample {
  cv::Vec3d median{0, 0, 0};  // per channel, over the inner region
  double spread = 0.0;        // median absolute deviation / median, largest channel
  PatchStatus status = PatchStatus::kOk;
  std::array<cv::Point2f, 4> inner_quad{};  // the sampled region, for drawing
};

struct PatchSampleOptions {
  double inner_fraction = 0.5;  // side of the sampled square relative to the patch pitch
  int samples_per_side = 12;    // grid of sample points inside it
  double max_spread = 0.08;     // above: kNonUniform (shadow edge, glare, occlusion)
  bool IsValid(std::string* why) const;
};

// Samples the 24 patches (reading order). Patches with a clipped pixel, or outside the
// image, are flagged and keep their median for display only.
std::vector<PatchSample> SamplePatches(const ChartImage& image, const ChartLocation& location,
                                       const PatchSampleOptions& options = {});

// Image point of a chart grid point.
cv::Point2f ImageFromGrid(const ChartLocation& location, cv::Point2f grid);

}  // namespace relume::calibration
