#include "calibration/undistort.h"

#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace relume::calibration {

bool HasDistortion(const std::vector<double>& distortion) {
  for (const double k : distortion) {
    if (k != 0.0) return true;
  }
  return false;
}

Undistorter::Undistorter(const PinholeIntrinsics& intrinsics, const std::vector<double>& distortion)
    : intrinsics_(intrinsics) {
  std::string why;
  if (!intrinsics.IsValid(&why)) throw InvalidArgumentError("undistortion: camera intrinsics: " + why);
  if (distortion.size() != 4 && distortion.size() != 5 && distortion.size() != 8) {
    throw InvalidArgumentError(
        "undistortion: expected 4, 5 or 8 distortion coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6]]), got " +
        std::to_string(distortion.size()));
  }
  for (const double k : distortion) {
    if (!std::isfinite(k)) throw InvalidArgumentError("undistortion: a distortion coefficient is not finite");
  }
  // relume's pixel centres are at integer + 0.5 (core/pinhole.h), OpenCV's at integers: the same
  // intrinsics shifted by half a pixel, in and out, keep the two conventions apart.
  const cv::Matx33d k_cv(intrinsics.fx, 0.0, intrinsics.cx - 0.5, 0.0, intrinsics.fy, intrinsics.cy - 0.5, 0.0, 0.0,
                         1.0);
  cv::initUndistortRectifyMap(k_cv, distortion, cv::noArray(), k_cv, cv::Size(intrinsics.width, intrinsics.height),
                              CV_32FC1, map_x_, map_y_);
  long long outside = 0;
  for (int y = 0; y < map_x_.rows; ++y) {
    const float* mx = map_x_.ptr<float>(y);
    const float* my = map_y_.ptr<float>(y);
    for (int x = 0; x < map_x_.cols; ++x) {
      // A source more than half a pixel beyond the outermost centres has no samples around it.
      if (!(mx[x] >= -0.5f && mx[x] <= intrinsics.width - 0.5f && my[x] >= -0.5f && my[x] <= intrinsics.height - 0.5f))
        ++outside;
    }
  }
  outside_fraction_ = static_cast<double>(outside) / static_cast<double>(map_x_.total());
}

void Undistorter::CheckSize(int width, int height, const char* what) const {
  if (width != intrinsics_.width || height != intrinsics_.height) {
    throw InvalidArgumentError(std::string("undistortion: the ") + what + " is " + std::to_string(width) + "x" +
                               std::to_string(height) + ", the camera's intrinsics are for " +
                               std::to_string(intrinsics_.width) + "x" + std::to_string(intrinsics_.height));
  }
}

RadianceImage Undistorter::Apply(const RadianceImage& radiance) const {
  CheckSize(radiance.width(), radiance.height(), "radiance image");
  RadianceImage out = radiance;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::remap(radiance.pixels, out.pixels, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(nan));
  return out;
}

cv::Mat Undistorter::ApplyNearest(const cv::Mat& labels, int fill) const {
  CheckSize(labels.cols, labels.rows, "label image");
  cv::Mat out;
  cv::remap(labels, out, map_x_, map_y_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(fill));
  return out;
}

cv::Mat Undistorter::ApplyDepth(const cv::Mat& depth_m) const {
  CheckSize(depth_m.cols, depth_m.rows, "depth image");
  if (depth_m.type() != CV_32FC1) throw InvalidArgumentError("Undistorter::ApplyDepth takes CV_32FC1 metres");
  cv::Mat out;
  cv::remap(depth_m, out, map_x_, map_y_, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
            cv::Scalar::all(std::numeric_limits<double>::quiet_NaN()));
  return out;
}

}  // namespace relume::calibration
