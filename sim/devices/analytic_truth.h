// Test support: a TruthSource made of planes and spheres lit by a point sun and a uniform
// ambient term, everything computed in closed form (ray-plane and ray-sphere intersections, a
// shadow ray per hit). It is test data with exactly known radiance, depth and normals, used by
// the simulated devices' tests and benchmarks; the real scene renderer is sim/world/.
//
// Conventions: sim/truth.h. Surfaces are Lambertian: radiance = albedo * irradiance / pi,
// irradiance = sun_irradiance * max(0, n . sun_dir) * visibility + ambient_irradiance. The sun
// is a point (visibility 0 or 1). A sphere moves with constant velocity from reference_time.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "sim/truth.h"

namespace relume::sim::testing {

struct AnalyticPlane {
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_in_world = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.5);
  // A checkerboard of `albedo` and `albedo_alt` with squares of this size (0: uniform).
  Eigen::Vector3d albedo_alt = Eigen::Vector3d::Constant(0.2);
  double checker_size_m = 0.0;
};

struct AnalyticSphere {
  Eigen::Vector3d centre_in_world = Eigen::Vector3d::Zero();
  double radius_m = 0.5;
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.8);
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();
};

struct AnalyticScene {
  std::vector<AnalyticPlane> planes;
  std::vector<AnalyticSphere> spheres;
  Eigen::Vector3d sun_dir_in_world = Eigen::Vector3d(0.3, -0.4, 0.866).normalized();
  Eigen::Vector3d sun_irradiance = Eigen::Vector3d::Constant(300.0);  // W m^-2 on a surface facing the sun
  Eigen::Vector3d ambient_irradiance = Eigen::Vector3d::Constant(60.0);
  Eigen::Vector3d sky_radiance = Eigen::Vector3d::Constant(20.0);  // where a ray hits nothing
  UtcTime reference_time{};
};

class AnalyticTruth : public TruthSource {
 public:
  explicit AnalyticTruth(AnalyticScene scene) : scene_(std::move(scene)) {}
  GroundTruth Render(const PinholeCamera& camera, UtcTime time) const override;
  const AnalyticScene& scene() const { return scene_; }

 private:
  AnalyticScene scene_;
};

// A camera at the origin looking along +x (world z up) and a scene for it: a checkered wall at
// x = wall_distance_m and a sphere in front of it. Small and fully visible.
AnalyticScene WallAndSphereScene(double wall_distance_m = 3.0);

}  // namespace relume::sim::testing
