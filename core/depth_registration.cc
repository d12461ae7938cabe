#include "core/depth_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <optional>

#include "core/error.h"

namespace relume {

namespace {
// Depth bilinearly interpolated at (x, y) in pixel-centre coordinates (centre of pixel i at
// i + 0.5), over the four samples around it that lie on the nearest one's surface (within
// edge_jump_fraction of its depth), their weights renormalised: next to a silhouette the
// surface is interpolated from its own side. nullopt outside the image, or when the samples on
// that surface carry less than a quarter of the weight.
std::optional<double> InterpolateDepth(const cv::Mat& depth_m, double x, double y, double edge_jump_fraction) {
  const double fx = x - 0.5, fy = y - 0.5;
  // Checked before the cast: a point far off the image (or NaN) has no int pixel.
  if (!(fx >= 0.0 && fy >= 0.0 && fx < depth_m.cols - 1 && fy < depth_m.rows - 1)) return std::nullopt;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double a = fx - x0, b = fy - y0;
  const double z[4] = {depth_m.at<float>(y0, x0), depth_m.at<float>(y0, x0 + 1), depth_m.at<float>(y0 + 1, x0),
                       depth_m.at<float>(y0 + 1, x0 + 1)};
  const double w[4] = {(1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b};
  double front = std::numeric_limits<double>::infinity();
  for (double zi : z) {
    if (std::isfinite(zi)) front = std::min(front, zi);
  }
  if (!std::isfinite(front)) return std::nullopt;
  double sum = 0.0, weight = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (std::isfinite(z[i]) && z[i] - front <= edge_jump_fraction * front) {
      sum += w[i] * z[i];
      weight += w[i];
    }
  }
  if (weight < 0.25) return std::nullopt;
  return sum / weight;
}
}  // namespace

cv::Mat RegisterDepthToColor(const cv::Mat& depth_m, const PinholeIntrinsics& depth_intrinsics,
                             const PinholeIntrinsics& color_intrinsics, const Eigen::Isometry3d& color_from_depth,
                             Registration method, double edge_jump_fraction) {
  RELUME_CHECK(depth_m.type() == CV_32FC1 && depth_m.cols == depth_intrinsics.width &&
               depth_m.rows == depth_intrinsics.height);
  RELUME_CHECK(edge_jump_fraction > 0.0);
  cv::Mat registered(color_intrinsics.height, color_intrinsics.width, CV_32FC1,
                     cv::Scalar(std::numeric_limits<float>::infinity()));
  for (int y = 0; y < depth_m.rows; ++y) {
    for (int x = 0; x < depth_m.cols; ++x) {
      const float z = depth_m.at<float>(y, x);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d point_in_color = color_from_depth * (z * depth_intrinsics.Unproject({x + 0.5, y + 0.5}));
      if (point_in_color.z() <= 0.0) continue;
      const Eigen::Vector2d uv = color_intrinsics.Project(point_in_color);
      if (!(uv.x() >= 0.0 && uv.y() >= 0.0 && uv.x() < color_intrinsics.width && uv.y() < color_intrinsics.height)) {
        continue;  // checked before the cast: far off the image there is no int pixel
      }
      const int u = static_cast<int>(uv.x()), v = static_cast<int>(uv.y());
      float& cell = registered.at<float>(v, u);
      cell = std::min(cell, static_cast<float>(point_in_color.z()));
    }
  }
  registered.setTo(std::numeric_limits<float>::quiet_NaN(), registered == std::numeric_limits<float>::infinity());
  if (method == Registration::kNearest) return registered;

  // Intersect each colour ray with the bilinear depth surface, starting from the nearest value.
  const Eigen::Isometry3d depth_from_color = color_from_depth.inverse();
  cv::Mat refined = registered.clone();
  for (int v = 0; v < registered.rows; ++v) {
    for (int u = 0; u < registered.cols; ++u) {
      double z = registered.at<float>(v, u);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d ray = color_intrinsics.Unproject({u + 0.5, v + 0.5});  // z = 1
      bool converged = false;
      for (int step = 0; step < 8 && !converged; ++step) {
        const Eigen::Vector3d in_depth = depth_from_color * (z * ray);
        if (in_depth.z() <= 0.0) break;
        const Eigen::Vector2d xy = depth_intrinsics.Project(in_depth);
        const std::optional<double> zd = InterpolateDepth(depth_m, xy.x(), xy.y(), edge_jump_fraction);
        if (!zd) break;
        // The depth surface's point on the depth ray through xy, seen from the colour camera;
        // its z is the next estimate for the colour ray (a fixed point on a smooth surface).
        const Eigen::Vector3d surface = color_from_depth * (*zd * depth_intrinsics.Unproject(xy));
        converged = std::abs(surface.z() - z) < 1e-7;
        z = surface.z();
      }
      if (converged) refined.at<float>(v, u) = static_cast<float>(z);
    }
  }
  return refined;
}

}  // namespace relume
