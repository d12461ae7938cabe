// Regions of uniform albedo (k-means on colour, optionally normals) and the sample points
// the SH fit reads, kept from frame to frame (Ogura et al., sample-point selection).
//
// Conventions:
//  - Features are chromaticity (r, g) / (r + g + b), so a bright and a dark part of the same
//    material fall in one segment (the shading is what the SH fit needs); with use_normals
//    the camera-frame normal, times normal_weight, is appended.
//  - Labels: CV_32SC1, -1 outside the mask or where the pixel is unusable (non-finite
//    colour, black, or no valid normal when normals are used). Segments are renumbered by
//    size, so label 0 is always the largest one.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/image.h"

namespace relume::processing {

struct SegmentationOptions {
  int segment_count = 4;
  bool use_normals = false;
  double normal_weight = 0.3;
  int max_cluster_pixels = 4000;  // k-means runs on at most this many pixels, then every pixel
                                  // joins its nearest centre
  int attempts = 3;
  int max_iterations = 30;
  std::uint64_t seed = 1;
  bool IsValid(std::string* why) const;
};

struct Segmentation {
  cv::Mat labels;                // CV_32SC1
  std::vector<int> pixel_count;  // per label; descending from SegmentByColor
  std::vector<cv::Vec3f> mean_color;
  // Per label, in label order: the k-means centre in feature space (CV_32F, one row of 2, or 5
  // with normals) and the RMS feature distance of the label's pixels to it. LabelByCentres
  // reads them to label another frame of the same scene.
  cv::Mat centres;
  std::vector<float> spread;
  cv::Vec3f frame_mean_color{0, 0, 0};  // over the usable pixels: the frame's colour balance
  int segment_count() const { return static_cast<int>(pixel_count.size()); }
};

// radiance: RGB RadianceImage; mask: CV_8UC1 (non-zero = object); normals: CV_32FC3 camera
// frame (may be empty unless use_normals). Fewer usable pixels than segments gives fewer
// segments (possibly none), never an error.
Segmentation SegmentByColor(const RadianceImage& radiance, const cv::Mat& mask, const cv::Mat& normal_in_camera,
                            const SegmentationOptions& options = {});

struct SamplePointOptions {
  int count = 2000;
  std::uint64_t seed = 7;
  bool IsValid(std::string* why) const;
};

// Keeps a set of sample pixels inside an allowed region across frames: points still inside
// stay; points that left are replaced by fresh random picks from the region.
class SamplePointSelector {
 public:
  explicit SamplePointSelector(const SamplePointOptions& options = {});
  // allowed: CV_8UC1, non-zero where a sample may be. Returns the current points (fewer than
  // count when the region is smaller).
  const std::vector<cv::Point>& Update(const cv::Mat& allowed);
  const std::vector<cv::Point>& points() const { return points_; }
  int kept_count() const { return kept_; }
  int reselected_count() const { return reselected_; }

 private:
  SamplePointOptions options_;
  std::mt19937_64 rng_;
  std::vector<cv::Point> points_;
  int kept_ = 0;
  int reselected_ = 0;
};

// Labels another frame of the same scene with `reference`'s segments (SegmentByColor's result for
// one frame, with the same options), so that a label names the same material in both:
//  - a usable pixel of same_surface (CV_8UC1 of the frame's size, may be empty: the pixels that
//    show the same surface point as in the reference frame, as in a static view) keeps the
//    reference's label there;
//  - any other usable pixel joins the nearest of reference's centres, unless it is farther from
//    it than max(max_spread_factor x that segment's spread, min_distance) (a material the
//    reference frame did not see), which leaves it unlabelled (-1).
// Labels keep reference's numbering, so pixel_count need not be descending and may hold zeros.
struct LabelByCentresOptions {
  double max_spread_factor = 4.0;
  double min_distance = 0.02;  // chromaticity units (with normals: feature units)
  // Map this frame's mean colour onto the reference's first (per channel, von Kries), so that
  // a light of another colour does not move the materials' chromaticities.
  bool balance_colour = true;
  bool IsValid(std::string* why) const;
};
Segmentation LabelByCentres(const Segmentation& reference, const RadianceImage& radiance, const cv::Mat& mask,
                            const cv::Mat& normal_in_camera, const SegmentationOptions& options,
                            const LabelByCentresOptions& label_options = {}, const cv::Mat& same_surface = {});

// The pixels of one label as a CV_8UC1 mask.
cv::Mat SegmentMask(const Segmentation& segmentation, int label);

}  // namespace relume::processing
