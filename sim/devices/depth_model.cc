#include "sim/devices/depth_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/core.hpp>
#include <optional>

#include "core/error.h"
#include "sim/devices/random.h"

namespace relume::sim {

bool DepthModelOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(min_range_m >= 0.0 && max_range_m > min_range_m && std::isfinite(max_range_m)))
    return fail("depth range needs 0 <= min_range_m < max_range_m (finite)");
  if (!(max_incidence_rad > 0.0 && max_incidence_rad <= std::numbers::pi / 2))
    return fail("max_incidence_rad must be within (0, pi/2]");
  if (!(edge_jump_fraction > 0.0)) return fail("edge_jump_fraction must be positive");
  if (!(sigma_base_m >= 0.0 && sigma_quadratic_per_m >= 0.0 && sigma_angle_coefficient >= 0.0 &&
        std::isfinite(sigma_reference_depth_m)))
    return fail("depth noise coefficients must be >= 0");
  if (!(projector_baseline_m > 0.0)) return fail("projector_baseline_m must be positive");
  if (!(disparity_step_px >= 0.0 && depth_step_m >= 0.0 && disparity_focal_px >= 0.0))
    return fail("quantisation steps and disparity_focal_px must be >= 0");
  return true;
}

double DepthSigma(double depth_m, double incidence_rad, const DepthModelOptions& options) {
  const double dz = depth_m - options.sigma_reference_depth_m;
  const double theta = std::min(incidence_rad, std::numbers::pi / 2 - 1e-6);
  const double angle = theta * theta / std::pow(std::numbers::pi / 2 - theta, 2);
  return options.sigma_base_m + options.sigma_quadratic_per_m * dz * dz +
         options.sigma_angle_coefficient / std::sqrt(depth_m) * angle;
}

cv::Mat MeasureDepth(const cv::Mat& truth_depth_m, const cv::Mat& normal_in_world, const PinholeCamera& camera,
                     const DepthModelOptions& options, std::uint64_t seed) {
  ThrowIfInvalid(options, "depth model options");
  const PinholeIntrinsics& k = camera.intrinsics;
  if (truth_depth_m.type() != CV_32FC1 || normal_in_world.type() != CV_32FC3 || truth_depth_m.cols != k.width ||
      truth_depth_m.rows != k.height || normal_in_world.size() != truth_depth_m.size()) {
    throw InvalidArgumentError("depth model: depth (CV_32FC1) and normals (CV_32FC3) must have the camera's size");
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Matrix3d camera_from_world = camera.world_from_camera.rotation().transpose();
  const double focal_px = options.disparity_focal_px > 0.0 ? options.disparity_focal_px : k.fx;
  const double focal_baseline = focal_px * options.projector_baseline_m;
  cv::Mat measured(truth_depth_m.size(), CV_32FC1);
  auto truth_at = [&](int x, int y) { return truth_depth_m.at<float>(y, x); };
  for (int y = 0; y < k.height; ++y) {
    Rng rng(StreamSeed(seed, static_cast<std::uint64_t>(y)));
    for (int x = 0; x < k.width; ++x) {
      const float z = truth_at(x, y);
      float& out = measured.at<float>(y, x);
      out = nan;
      if (!(z >= options.min_range_m && z <= options.max_range_m)) continue;  // NaN fails too
      const cv::Vec3f& n = normal_in_world.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d normal_in_camera = camera_from_world * Eigen::Vector3d(n[0], n[1], n[2]);
      const Eigen::Vector3d ray = k.Unproject({x + 0.5, y + 0.5}).normalized();
      const double cos_incidence = std::abs(normal_in_camera.dot(ray));
      if (!std::isfinite(cos_incidence)) continue;
      const double incidence = std::acos(std::min(1.0, cos_incidence));
      if (incidence > options.max_incidence_rad) continue;
      bool edge = false;
      const int dx[] = {1, -1, 0, 0}, dy[] = {0, 0, 1, -1};
      for (int i = 0; i < 4 && !edge; ++i) {
        const int nx = x + dx[i], ny = y + dy[i];
        if (nx < 0 || ny < 0 || nx >= k.width || ny >= k.height) continue;
        const float neighbour = truth_at(nx, ny);
        edge = !(std::abs(neighbour - z) <= options.edge_jump_fraction * z);
      }
      if (edge) continue;
      double value = z;
      const double draw = rng.Normal();  // drawn for every pixel kept, so rows stay aligned
      if (options.noise) value += DepthSigma(z, incidence, options) * draw;
      if (options.disparity_step_px > 0.0 && value > 0.0) {
        const double disparity =
            std::nearbyint(focal_baseline / value / options.disparity_step_px) * options.disparity_step_px;
        value = disparity > 0.0 ? focal_baseline / disparity : std::numeric_limits<double>::quiet_NaN();
      }
      if (options.depth_step_m > 0.0) value = std::nearbyint(value / options.depth_step_m) * options.depth_step_m;
      if (value >= options.min_range_m && value <= options.max_range_m) out = static_cast<float>(value);
    }
  }
  return measured;
}

}  // namespace relume::sim
