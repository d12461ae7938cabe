// Test data for relume_processing only: an ideal RGB-D view of analytic objects with uniform
// Lambertian albedos under a known SH light, and a separate function that adds Kinect-like
// depth noise (truth and noise never mix). This is not the simulated sensor (sim/devices/);
// integration tests against that come later.
//
// Conventions: camera frame (x right, y down, z forward, metres); pixel (u, v) is the ray
// through (u + 0.5, v + 0.5); radiance = albedo * E(n) / pi with E from the SH light in the
// camera frame (processing/sh.h). Environment maps are lat-long with +z up; CameraFromMap()
// turns them into the camera frame (map +x = camera +x, map +y = camera +z, map +z = -y).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"
#include "processing/sh.h"

namespace relume::processing::testing {

// Object ids in SyntheticFrame::object_id.
enum SceneObject : int { kNone = -1, kBigSphere = 0, kSmallSphere = 1, kBox = 2, kWall = 3 };

struct SceneOptions {
  PinholeIntrinsics intrinsics = PinholeIntrinsics::FromHorizontalFov(320, 240, 60.0 * 3.14159265358979 / 180.0);
  bool with_wall = true;  // a grey wall behind the objects (not part of the object mask)
  Eigen::Vector3d big_sphere_albedo{0.75, 0.55, 0.45};
  Eigen::Vector3d small_sphere_albedo{0.20, 0.35, 0.75};
  Eigen::Vector3d box_albedo{0.30, 0.60, 0.25};
  Eigen::Vector3d wall_albedo{0.50, 0.50, 0.50};
};

struct SyntheticFrame {
  RadianceImage radiance;    // RGB; 0 where no surface
  cv::Mat depth_m;           // CV_32FC1, exact; NaN where no surface
  cv::Mat normal_in_camera;  // CV_32FC3, exact, facing the camera; NaN where none
  cv::Mat albedo;            // CV_32FC3; NaN where none
  cv::Mat irradiance;        // CV_32FC3, E(n) of the light; NaN where none
  cv::Mat object_id;         // CV_32SC1
  cv::Mat object_mask;       // CV_8UC1: the two spheres and the box (not the wall)
};

SyntheticFrame RenderScene(const SceneOptions& options, const ShRgb& light_in_camera);

// Any scene of spheres and oriented boxes before an optional wall (the fixed scene above is
// one), lit by any distant light given as its irradiance E(n) for a camera-frame unit normal
// (no visibility: nothing casts a shadow). object_id is the index in `objects`, the wall's id
// is objects.size(); object_mask covers the objects, not the wall.
struct Primitive {
  enum class Kind { kSphere, kBox } kind = Kind::kSphere;
  Eigen::Vector3d centre = Eigen::Vector3d(0, 0, 1);  // camera frame, metres
  double radius = 0.1;                                // sphere
  Eigen::Matrix3d camera_from_box = Eigen::Matrix3d::Identity();
  Eigen::Vector3d half_extents = Eigen::Vector3d::Constant(0.05);  // box
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.5);
};
struct PrimitiveScene {
  PinholeIntrinsics intrinsics = PinholeIntrinsics::FromHorizontalFov(320, 240, 60.0 * 3.14159265358979 / 180.0);
  std::vector<Primitive> objects;
  bool with_wall = true;
  double wall_depth_m = 1.5;  // the plane z = wall_depth_m, facing the camera
  Eigen::Vector3d wall_albedo{0.5, 0.5, 0.5};
};
using IrradianceFunction = std::function<Eigen::Vector3d(const Eigen::Vector3d& normal_in_camera)>;
SyntheticFrame RenderPrimitives(const PrimitiveScene& scene, const IrradianceFunction& irradiance);

// Kinect-like axial noise: sigma(z) = 1.2e-3 + 1.9e-3 (z - 0.4)^2 metres, Gaussian, per pixel.
double KinectDepthSigmaM(double depth_m);
cv::Mat AddKinectDepthNoise(const cv::Mat& depth_m, std::uint64_t seed);

// A smooth sky with a sun-like lobe, lat-long (+z up), linear RGB radiance.
struct SkySunOptions {
  Eigen::Vector3d sun_dir_in_map = Eigen::Vector3d(0.5, -0.3, 0.8).normalized();
  Eigen::Vector3d sun_radiance{6.0, 5.6, 4.8};  // peak of the lobe
  double sun_sharpness = 40.0;                  // lobe = exp(sharpness (cos angle - 1))
  Eigen::Vector3d zenith_radiance{0.35, 0.50, 0.85};
  Eigen::Vector3d horizon_radiance{0.80, 0.85, 0.90};
  Eigen::Vector3d ground_radiance{0.25, 0.22, 0.18};
};
RadianceImage MakeSkySunMap(int width, int height, const SkySunOptions& options);
Eigen::Matrix3d CameraFromMap();

}  // namespace relume::processing::testing
