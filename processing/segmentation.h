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
  std::vector<int> pixel_count;  // per label, descending
  std::vector<cv::Vec3f> mean_color;
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

// The pixels of one label as a CV_8UC1 mask.
cv::Mat SegmentMask(const Segmentation& segmentation, int label);

}  // namespace relume::processing
