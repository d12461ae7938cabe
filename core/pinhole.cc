#include "core/pinhole.h"

#include <cmath>

#include "core/error.h"

namespace relume {

PinholeIntrinsics PinholeIntrinsics::FromHorizontalFov(int width, int height, double horizontal_fov_rad) {
  PinholeIntrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * horizontal_fov_rad);
  k.cx = 0.5 * width;
  k.cy = 0.5 * height;
  return k;
}

bool PinholeIntrinsics::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (width <= 0 || height <= 0) return fail("image size must be positive");
  if (std::int64_t{width} * height > kMaxPixels) {
    if (why) {
      *why = "image size " + std::to_string(width) + "x" + std::to_string(height) +
             " is more than relume's maximum of 2^28 (268 million) pixels";
    }
    return false;
  }
  if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0)) return fail("focal lengths must be positive");
  if (!(std::isfinite(cx) && std::isfinite(cy))) return fail("principal point must be finite");
  return true;
}

PinholeCamera PinholeCamera::LookAt(const PinholeIntrinsics& intrinsics, const Eigen::Vector3d& eye,
                                    const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d forward = (target - eye).normalized();
  Eigen::Vector3d right = forward.cross(up);
  RELUME_CHECK_MSG(right.norm() > 1e-9, "LookAt: view direction parallel to up");
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);
  PinholeCamera camera;
  camera.intrinsics = intrinsics;
  Eigen::Matrix3d rotation;
  rotation.col(0) = right;  // camera x in world
  rotation.col(1) = down;   // camera y
  rotation.col(2) = forward;
  camera.world_from_camera.linear() = rotation;
  camera.world_from_camera.translation() = eye;
  return camera;
}

}  // namespace relume
