#include "calibration/testing/lens.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace relume::calibration::testing {

std::vector<cv::Point2d> NormalisedPointsThroughLens(const PinholeIntrinsics& k, const std::vector<double>& d) {
  // OpenCV's pixel centres are at integers: the same intrinsics shifted by half a pixel.
  const cv::Matx33d k_cv(k.fx, 0.0, k.cx - 0.5, 0.0, k.fy, k.cy - 0.5, 0.0, 0.0, 1.0);
  std::vector<cv::Point2d> pixels, normalised;
  pixels.reserve(static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height));
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) pixels.emplace_back(u, v);
  cv::undistortPoints(pixels, normalised, k_cv, d, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-12));
  return normalised;
}

cv::Mat ThroughLens(const cv::Mat& pinhole, const PinholeIntrinsics& k, const std::vector<double>& d,
                    int interpolation) {
  const std::vector<cv::Point2d> normalised = NormalisedPointsThroughLens(k, d);
  cv::Mat map_x(k.height, k.width, CV_32FC1), map_y(k.height, k.width, CV_32FC1);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const cv::Point2d& n = normalised[static_cast<std::size_t>(v * k.width + u)];
      map_x.at<float>(v, u) = static_cast<float>(n.x * k.fx + k.cx - 0.5);
      map_y.at<float>(v, u) = static_cast<float>(n.y * k.fy + k.cy - 0.5);
    }
  }
  cv::Mat out;
  cv::remap(pinhole, out, map_x, map_y, interpolation, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace relume::calibration::testing
