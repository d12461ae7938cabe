// Frames taken through a lens with distortion, resampled onto the pinhole camera with the same
// intrinsics, so that the pipelines (which project meshes and normals through a pinhole) can use
// them. The model is OpenCV's (k1, k2, p1, p2[, k3[, k4, k5, k6]]), the one `relume calibrate
// intrinsics` fits and a scene model's camera stores (core/scene_model.h).
//
// Each output pixel centre is mapped through the distortion to where the lens put it
// (cv::initUndistortRectifyMap with the camera's own intrinsics as the new ones) and the frame
// is sampled there: bilinearly for radiance (values proportional to light interpolate
// physically), nearest for label images (HDR status, masks). Output pixels whose source lies
// outside the frame are NaN (radiance) or `fill` (labels), never clamped edge values.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"

namespace relume::calibration {

// True when any coefficient is non-zero.
bool HasDistortion(const std::vector<double>& distortion);

class Undistorter {
 public:
  // `distortion`: 4, 5 or 8 coefficients in OpenCV's order. Throws InvalidArgumentError for
  // another count, non-finite coefficients or invalid intrinsics.
  Undistorter(const PinholeIntrinsics& intrinsics, const std::vector<double>& distortion);

  const PinholeIntrinsics& intrinsics() const { return intrinsics_; }
  // Output pixels whose source lies outside the frame (NaN after Apply).
  double outside_fraction() const { return outside_fraction_; }

  // Throws InvalidArgumentError when the image's size is not the intrinsics'.
  RadianceImage Apply(const RadianceImage& radiance) const;
  // CV_8UC1 labels, nearest neighbour.
  cv::Mat ApplyNearest(const cv::Mat& labels, int fill) const;
  // CV_32FC1 depth (metres) registered to the distorted image, nearest neighbour (depth does not
  // interpolate across silhouettes); NaN where the source lies outside.
  cv::Mat ApplyDepth(const cv::Mat& depth_m) const;

 private:
  void CheckSize(int width, int height, const char* what) const;

  PinholeIntrinsics intrinsics_;
  cv::Mat map_x_, map_y_;  // CV_32FC1: where each output pixel comes from
  double outside_fraction_ = 0.0;
};

}  // namespace relume::calibration
