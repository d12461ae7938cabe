#include "sim/devices/analytic_truth.h"

#include <cmath>
#include <limits>
#include <numbers>

namespace relume::sim::testing {
namespace {

constexpr double kNoHit = std::numeric_limits<double>::infinity();

struct Hit {
  double t = kNoHit;  // ray parameter; with a direction of camera z = 1 it is the depth
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();
  int object_id = -1;
};

double IntersectPlane(const AnalyticPlane& plane, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  const Eigen::Vector3d n = plane.normal_in_world.normalized();
  const double denominator = n.dot(direction);
  if (std::abs(denominator) < 1e-12) return kNoHit;
  const double t = n.dot(plane.point_in_world - origin) / denominator;
  return t > 0.0 ? t : kNoHit;
}

double IntersectSphere(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& direction) {
  const Eigen::Vector3d oc = origin - centre;
  const double a = direction.squaredNorm();
  const double half_b = oc.dot(direction);
  const double c = oc.squaredNorm() - radius * radius;
  const double discriminant = half_b * half_b - a * c;
  if (discriminant < 0.0) return kNoHit;
  const double root = std::sqrt(discriminant);
  // The stable form of the smaller root, then the larger when the origin is inside.
  const double q = -half_b - std::copysign(root, half_b);
  double t0 = q / a, t1 = c / q;
  if (t0 > t1) std::swap(t0, t1);
  if (t0 > 1e-9) return t0;
  if (t1 > 1e-9) return t1;
  return kNoHit;
}

Eigen::Vector3d SphereCentre(const AnalyticSphere& sphere, UtcTime reference, UtcTime time) {
  const double elapsed_s = std::chrono::duration<double>(time - reference).count();
  return sphere.centre_in_world + sphere.velocity_m_per_s * elapsed_s;
}

Eigen::Vector3d PlaneAlbedo(const AnalyticPlane& plane, const Eigen::Vector3d& point) {
  if (plane.checker_size_m <= 0.0) return plane.albedo;
  // Two axes in the plane, fixed by its normal, give the checker parity.
  const Eigen::Vector3d n = plane.normal_in_world.normalized();
  const Eigen::Vector3d helper = std::abs(n.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d u = helper.cross(n).normalized();
  const Eigen::Vector3d v = n.cross(u);
  const Eigen::Vector3d local = point - plane.point_in_world;
  const long i = std::lround(std::floor(local.dot(u) / plane.checker_size_m));
  const long j = std::lround(std::floor(local.dot(v) / plane.checker_size_m));
  return ((i + j) & 1) == 0 ? plane.albedo : plane.albedo_alt;
}

}  // namespace

GroundTruth AnalyticTruth::Render(const PinholeCamera& camera, UtcTime time) const {
  const PinholeIntrinsics& k = camera.intrinsics;
  GroundTruth truth;
  truth.radiance = MakeRadianceImage(k.width, k.height, RadianceUnit::kWattsPerSqmPerSr);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  truth.depth_m.create(k.height, k.width, CV_32FC1);
  truth.normal_in_world.create(k.height, k.width, CV_32FC3);
  truth.albedo.create(k.height, k.width, CV_32FC3);
  truth.sun_visibility.create(k.height, k.width, CV_32FC1);
  truth.irradiance.create(k.height, k.width, CV_32FC3);
  truth.object_id.create(k.height, k.width, CV_32SC1);

  std::vector<Eigen::Vector3d> centres;
  for (const AnalyticSphere& sphere : scene_.spheres)
    centres.push_back(SphereCentre(sphere, scene_.reference_time, time));
  const Eigen::Vector3d origin = camera.world_from_camera.translation();
  const Eigen::Matrix3d rotation = camera.world_from_camera.rotation();
  const Eigen::Vector3d sun = scene_.sun_dir_in_world.normalized();
  const int plane_count = static_cast<int>(scene_.planes.size());

  auto first_hit = [&](const Eigen::Vector3d& from, const Eigen::Vector3d& direction) {
    Hit hit;
    for (int i = 0; i < plane_count; ++i) {
      const double t = IntersectPlane(scene_.planes[i], from, direction);
      if (t < hit.t) {
        hit.t = t;
        hit.object_id = i;
      }
    }
    for (std::size_t i = 0; i < centres.size(); ++i) {
      const double t = IntersectSphere(centres[i], scene_.spheres[i].radius_m, from, direction);
      if (t < hit.t) {
        hit.t = t;
        hit.object_id = plane_count + static_cast<int>(i);
      }
    }
    return hit;
  };

  for (int y = 0; y < k.height; ++y) {
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d direction = rotation * k.Unproject({x + 0.5, y + 0.5});
      Hit hit = first_hit(origin, direction);
      cv::Vec3f& radiance = truth.radiance.pixels.at<cv::Vec3f>(y, x);
      if (hit.object_id < 0) {
        radiance = cv::Vec3f(scene_.sky_radiance.cast<float>().x(), scene_.sky_radiance.cast<float>().y(),
                             scene_.sky_radiance.cast<float>().z());
        truth.depth_m.at<float>(y, x) = nan;
        truth.normal_in_world.at<cv::Vec3f>(y, x) = cv::Vec3f::all(nan);
        truth.albedo.at<cv::Vec3f>(y, x) = cv::Vec3f::all(nan);
        truth.sun_visibility.at<float>(y, x) = 0.0f;
        truth.irradiance.at<cv::Vec3f>(y, x) = cv::Vec3f::all(0.0f);
        truth.object_id.at<int>(y, x) = -1;
        continue;
      }
      const Eigen::Vector3d point = origin + hit.t * direction;
      if (hit.object_id < plane_count) {
        hit.normal = scene_.planes[hit.object_id].normal_in_world.normalized();
        hit.albedo = PlaneAlbedo(scene_.planes[hit.object_id], point);
      } else {
        const int s = hit.object_id - plane_count;
        hit.normal = (point - centres[s]).normalized();
        hit.albedo = scene_.spheres[s].albedo;
      }
      if (hit.normal.dot(direction) > 0.0) hit.normal = -hit.normal;  // face the camera
      const double cos_sun = hit.normal.dot(sun);
      double visibility = 0.0;
      if (cos_sun > 0.0) {
        const Hit blocker = first_hit(point + 1e-6 * hit.normal, sun);
        visibility = blocker.object_id < 0 ? 1.0 : 0.0;
      }
      const Eigen::Vector3d irradiance =
          scene_.sun_irradiance * (std::max(0.0, cos_sun) * visibility) + scene_.ambient_irradiance;
      const Eigen::Vector3d value = hit.albedo.cwiseProduct(irradiance) / std::numbers::pi;
      radiance = cv::Vec3f(static_cast<float>(value.x()), static_cast<float>(value.y()), static_cast<float>(value.z()));
      truth.depth_m.at<float>(y, x) = static_cast<float>(hit.t);
      truth.normal_in_world.at<cv::Vec3f>(y, x) = cv::Vec3f(
          static_cast<float>(hit.normal.x()), static_cast<float>(hit.normal.y()), static_cast<float>(hit.normal.z()));
      truth.albedo.at<cv::Vec3f>(y, x) = cv::Vec3f(
          static_cast<float>(hit.albedo.x()), static_cast<float>(hit.albedo.y()), static_cast<float>(hit.albedo.z()));
      truth.sun_visibility.at<float>(y, x) = static_cast<float>(visibility);
      truth.irradiance.at<cv::Vec3f>(y, x) = cv::Vec3f(
          static_cast<float>(irradiance.x()), static_cast<float>(irradiance.y()), static_cast<float>(irradiance.z()));
      truth.object_id.at<int>(y, x) = hit.object_id;
    }
  }
  return truth;
}

AnalyticScene WallAndSphereScene(double wall_distance_m) {
  AnalyticScene scene;
  AnalyticPlane wall;
  wall.point_in_world = Eigen::Vector3d(wall_distance_m, 0.0, 0.0);
  wall.normal_in_world = -Eigen::Vector3d::UnitX();
  wall.albedo = Eigen::Vector3d(0.7, 0.6, 0.5);
  wall.albedo_alt = Eigen::Vector3d(0.15, 0.2, 0.25);
  wall.checker_size_m = 0.25;
  scene.planes.push_back(wall);
  AnalyticSphere sphere;
  sphere.centre_in_world = Eigen::Vector3d(0.6 * wall_distance_m, 0.2, 0.0);
  sphere.radius_m = 0.15 * wall_distance_m;
  scene.spheres.push_back(sphere);
  // The sun behind the camera and above, so that the wall and the sphere are lit.
  scene.sun_dir_in_world = Eigen::Vector3d(-0.6, -0.3, 0.74).normalized();
  return scene;
}

}  // namespace relume::sim::testing
