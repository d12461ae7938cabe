#include "processing/testing/synthetic_scene.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

namespace relume::processing::testing {
namespace {

struct Hit {
  double t = std::numeric_limits<double>::infinity();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int id = kNone;
};

void IntersectSphere(const Eigen::Vector3d& d, const Eigen::Vector3d& centre, double radius, int id, Hit* hit) {
  const double a = d.squaredNorm(), b = d.dot(centre), c = centre.squaredNorm() - radius * radius;
  const double disc = b * b - a * c;
  if (disc < 0.0) return;
  const double t = (b - std::sqrt(disc)) / a;
  if (t <= 0.0 || t >= hit->t) return;
  hit->t = t;
  hit->normal = (t * d - centre) / radius;
  hit->id = id;
}

// An oriented box: centre, rotation camera_from_box and half extents.
void IntersectBox(const Eigen::Vector3d& d, const Eigen::Vector3d& centre, const Eigen::Matrix3d& camera_from_box,
                  const Eigen::Vector3d& half, int id, Hit* hit) {
  const Eigen::Vector3d o = camera_from_box.transpose() * (-centre);
  const Eigen::Vector3d dir = camera_from_box.transpose() * d;
  double t_near = -std::numeric_limits<double>::infinity(), t_far = std::numeric_limits<double>::infinity();
  int axis = -1;
  double sign = 0.0;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(dir(i)) < 1e-15) {
      if (std::abs(o(i)) > half(i)) return;
      continue;
    }
    double t0 = (-half(i) - o(i)) / dir(i), t1 = (half(i) - o(i)) / dir(i);
    double s = -1.0;  // entering through the -half face
    if (t0 > t1) std::swap(t0, t1), s = 1.0;
    if (t0 > t_near) t_near = t0, axis = i, sign = s;
    t_far = std::min(t_far, t1);
  }
  if (t_near > t_far || t_near <= 0.0 || t_near >= hit->t || axis < 0) return;
  hit->t = t_near;
  hit->normal = camera_from_box.col(axis) * sign;
  hit->id = id;
}

}  // namespace

SyntheticFrame RenderPrimitives(const PrimitiveScene& scene, const IrradianceFunction& irradiance) {
  const PinholeIntrinsics& k = scene.intrinsics;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int wall_id = static_cast<int>(scene.objects.size());
  SyntheticFrame f;
  f.radiance = MakeRadianceImage(k.width, k.height);
  f.depth_m = cv::Mat(k.height, k.width, CV_32FC1, cv::Scalar(nan));
  f.normal_in_camera = cv::Mat(k.height, k.width, CV_32FC3, cv::Scalar(nan, nan, nan));
  f.albedo = f.normal_in_camera.clone();
  f.irradiance = f.normal_in_camera.clone();
  f.object_id = cv::Mat(k.height, k.width, CV_32SC1, cv::Scalar(kNone));
  f.object_mask = cv::Mat::zeros(k.height, k.width, CV_8UC1);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d d = k.Unproject({u + 0.5, v + 0.5});  // z = 1, so t is depth
      Hit hit;
      for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const Primitive& o = scene.objects[i];
        if (o.kind == Primitive::Kind::kSphere) {
          IntersectSphere(d, o.centre, o.radius, static_cast<int>(i), &hit);
        } else {
          IntersectBox(d, o.centre, o.camera_from_box, o.half_extents, static_cast<int>(i), &hit);
        }
      }
      if (scene.with_wall && hit.id == kNone) hit = {scene.wall_depth_m, {0.0, 0.0, -1.0}, wall_id};
      if (hit.id == kNone) continue;
      const Eigen::Vector3d& rho = hit.id == wall_id ? scene.wall_albedo : scene.objects[hit.id].albedo;
      const Eigen::Vector3d e = irradiance(hit.normal);
      const Eigen::Vector3d radiance = rho.cwiseProduct(e) / std::numbers::pi;
      f.depth_m.at<float>(v, u) = static_cast<float>(hit.t);
      f.normal_in_camera.at<cv::Vec3f>(v, u) = cv::Vec3f(hit.normal.x(), hit.normal.y(), hit.normal.z());
      f.albedo.at<cv::Vec3f>(v, u) = cv::Vec3f(rho.x(), rho.y(), rho.z());
      f.irradiance.at<cv::Vec3f>(v, u) = cv::Vec3f(e.x(), e.y(), e.z());
      f.radiance.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f(radiance.x(), radiance.y(), radiance.z());
      f.object_id.at<int>(v, u) = hit.id;
      if (hit.id != wall_id) f.object_mask.at<unsigned char>(v, u) = 255;
    }
  }
  return f;
}

SyntheticFrame RenderScene(const SceneOptions& options, const ShRgb& light_in_camera) {
  PrimitiveScene scene;
  scene.intrinsics = options.intrinsics;
  scene.with_wall = options.with_wall;
  scene.wall_depth_m = 1.5;
  scene.wall_albedo = options.wall_albedo;
  Primitive big, small, box;
  big.centre = {-0.08, 0.02, 1.0};
  big.radius = 0.20;
  big.albedo = options.big_sphere_albedo;
  small.centre = {0.21, -0.15, 0.92};
  small.radius = 0.07;
  small.albedo = options.small_sphere_albedo;
  box.kind = Primitive::Kind::kBox;
  box.centre = {0.21, 0.13, 0.95};
  box.camera_from_box =
      (Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.45, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  box.half_extents = {0.07, 0.06, 0.07};
  box.albedo = options.box_albedo;
  scene.objects = {big, small, box};  // ids kBigSphere, kSmallSphere, kBox; the wall is kWall
  return RenderPrimitives(scene, [&](const Eigen::Vector3d& n) { return ShIrradiance(light_in_camera, n); });
}

double KinectDepthSigmaM(double depth_m) {
  return 1.2e-3 + 1.9e-3 * (depth_m - 0.4) * (depth_m - 0.4);
}

cv::Mat AddKinectDepthNoise(const cv::Mat& depth_m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  cv::Mat out = depth_m.clone();
  for (int y = 0; y < out.rows; ++y) {
    float* z = out.ptr<float>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (std::isfinite(z[x])) z[x] = static_cast<float>(z[x] + KinectDepthSigmaM(z[x]) * gauss(rng));
    }
  }
  return out;
}

RadianceImage MakeSkySunMap(int width, int height, const SkySunOptions& options) {
  RadianceImage map = MakeRadianceImage(width, height);
  const Eigen::Vector3d sun = options.sun_dir_in_map.normalized();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d w = LatLongDirection(u + 0.5, v + 0.5, width, height);
      Eigen::Vector3d radiance;
      if (w.z() >= 0.0) {
        const double blend = std::pow(1.0 - w.z(), 3.0);  // horizon brightening
        radiance = options.zenith_radiance * (1.0 - blend) + options.horizon_radiance * blend;
      } else {
        radiance = options.ground_radiance;
      }
      radiance += options.sun_radiance * std::exp(options.sun_sharpness * (w.dot(sun) - 1.0));
      map.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f(radiance.x(), radiance.y(), radiance.z());
    }
  }
  return map;
}

Eigen::Matrix3d CameraFromMap() {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(1, 0, 0);   // map east-ish x -> camera x
  r.col(1) = Eigen::Vector3d(0, 0, 1);   // map y -> camera forward
  r.col(2) = Eigen::Vector3d(0, -1, 0);  // map up -> image up
  return r;
}

}  // namespace relume::processing::testing
