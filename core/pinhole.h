// Pinhole camera geometry shared by the simulator, the drivers and processing.
//
// Conventions:
//  - Camera frame (OpenCV's): x right, y down, z forward along the optical axis, metres.
//  - Pixel centres at (u + 0.5, v + 0.5) (core/image.h): a ray through pixel (u, v) passes
//    through image point (u + 0.5, v + 0.5). cx, cy are in the same continuous coordinates,
//    so an ideal centred principal point is (width / 2, height / 2).
//  - Poses are named target_from_source: `world_from_camera` maps a point in camera
//    coordinates to world (scene, ENU) coordinates.
//  - No lens distortion here; a distortion model, when needed, is a separate stage.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

namespace relume {

struct PinholeIntrinsics {
  // The largest image relume accepts: 2^28 pixels (16384 x 16384). Images are cv::Mats of up
  // to 4 float channels whose element counts and offsets are ints in OpenCV and in relume's
  // loops; 2^28 x 4 stays below 2^31, and at 16 bytes a pixel the image is 4 GiB. Sizes are
  // checked against it before anything is allocated.
  static constexpr std::int64_t kMaxPixels = std::int64_t{1} << 28;

  int width = 0;
  int height = 0;
  double fx = 0.0;  // focal length in pixels
  double fy = 0.0;
  double cx = 0.0;  // principal point in continuous pixel coordinates
  double cy = 0.0;

  // A centred camera with the given horizontal field of view (radians) and square pixels.
  static PinholeIntrinsics FromHorizontalFov(int width, int height, double horizontal_fov_rad);
  bool IsValid(std::string* why) const;

  // Image point (continuous pixel coordinates) of a point in the camera frame (z > 0).
  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_camera) const {
    return {fx * point_in_camera.x() / point_in_camera.z() + cx, fy * point_in_camera.y() / point_in_camera.z() + cy};
  }
  // Direction (z = 1) in the camera frame through a continuous image point.
  Eigen::Vector3d Unproject(const Eigen::Vector2d& image_point) const {
    return {(image_point.x() - cx) / fx, (image_point.y() - cy) / fy, 1.0};
  }
};

// A camera placed in the world: intrinsics plus world_from_camera.
struct PinholeCamera {
  PinholeIntrinsics intrinsics;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();

  // A camera at `eye` looking at `target`, with the image's up as close to `up` as possible.
  static PinholeCamera LookAt(const PinholeIntrinsics& intrinsics, const Eigen::Vector3d& eye,
                              const Eigen::Vector3d& target, const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());
};

}  // namespace relume
