// Scene description for radiosity: a triangle mesh with Lambertian materials, and lights.
//
// Conventions (stated once, here):
//  - Positions in metres in the scene frame; for outdoor scenes that frame is local
//    East-North-Up (z up), which the sky model uses to tell sky from ground.
//  - Each triangle is one-sided: its front is where the normal (v1 - v0) x (v2 - v0) points
//    (counter-clockwise seen from the front). Light arriving at, or leaving, the back of a
//    triangle is ignored; the back still blocks rays.
//  - Colours are linear RGB triples (Eigen::Vector3d, R, G, B).
//  - Radiometry: irradiance E and radiosity B in W m^-2 (or a relative unit, consistently),
//    radiance L = B / pi for a Lambertian surface; point-light intensity in W sr^-1.
//  - Albedo (diffuse reflectance) per channel in [0, 1].
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace relume::radiosity {

using Rgb = Eigen::Vector3d;

struct Material {
  std::string name;
  Rgb albedo = Rgb::Constant(0.5);      // in [0, 1] per channel
  Rgb emitted_radiosity = Rgb::Zero();  // self-emission, W m^-2 (0 for non-luminaires)
};

// The scene's surfaces: core's triangle mesh, whose per-triangle material ids index `materials`.
// The same TriangleMesh is what relume::RayCaster takes (`const RayCaster caster(mesh.geometry);`),
// so a triangle index means the same to the solver and to the rays. Positions are float metres
// in the scene frame, a local one: float steps are 1 um within 8 m of its origin, 61 um at 1 km.
struct Mesh {
  TriangleMesh geometry;  // positions, triangles and material (one id per triangle); the rest unused
  std::vector<Material> materials;

  // Adds a material and returns its index.
  int AddMaterial(const Material& material);
  // Adds the planar quad a, b, c, d (counter-clockwise seen from its front) as two triangles.
  void AddQuad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d,
               int material);
  // Adds the triangle a, b, c (counter-clockwise seen from its front).
  void AddTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, int material);
  // Adds an axis-aligned box [lo, hi] with outward-facing sides. `skip_bottom` leaves out the
  // face at z = lo.z (a box resting on the floor).
  void AddBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int material, bool skip_bottom = false);
  // Adds an axis-aligned room [lo, hi] seen from inside (normals point inwards): floor,
  // ceiling and four walls, each with its own material index.
  void AddRoom(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int floor, int ceiling, int walls);

  int TriangleCount() const { return static_cast<int>(geometry.triangles.size()); }
  // Corner k (0-2) of triangle t, in double precision for the solver's geometry.
  Eigen::Vector3d Corner(int t, int k) const {
    return geometry.positions[static_cast<std::size_t>(geometry.triangles[static_cast<std::size_t>(t)][k])]
        .cast<double>();
  }
  // Triangle t's material.
  const Material& MaterialOf(int t) const {
    return materials[static_cast<std::size_t>(geometry.material[static_cast<std::size_t>(t)])];
  }
  // False with the reason for: bad indices, a material id missing or out of range, non-finite
  // positions, degenerate (zero-area) triangles, albedo outside [0, 1], negative or non-finite
  // emission.
  bool IsValid(std::string* why) const;
};

// A point lamp: isotropic, or a spot when spot_direction is non-zero. A spot has full
// intensity within cone_half_angle_rad - falloff_rad of spot_direction and falls smoothly
// (smoothstep) to 0 at cone_half_angle_rad, the model of sim/world's spots.
struct PointLight {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Rgb intensity_w_per_sr = Rgb::Constant(1.0);
  Eigen::Vector3d spot_direction = Eigen::Vector3d::Zero();  // zero: isotropic
  double cone_half_angle_rad = 0.0;
  double falloff_rad = 0.0;
  // Intensity factor in [0, 1] toward the unit direction `direction_from_light`.
  double SpotFactor(const Eigen::Vector3d& direction_from_light) const;
};

// A one-sided Lambertian luminaire: the parallelogram corner + s*edge_u + t*edge_v, s, t in
// [0, 1], emitting radiance `radiance` to the side of edge_u x edge_v. It lights the mesh
// but is not part of it (it blocks no rays and receives no light).
struct AreaLight {
  Eigen::Vector3d corner_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d edge_u_m = Eigen::Vector3d::UnitX();
  Eigen::Vector3d edge_v_m = Eigen::Vector3d::UnitY();
  Rgb radiance = Rgb::Constant(1.0);  // W m^-2 sr^-1
};

// A distant sun and a uniform sky dome over the upper hemisphere (z > 0 in the scene frame).
struct SunSky {
  Eigen::Vector3d sun_dir_in_scene = Eigen::Vector3d::UnitZ();  // towards the sun, unit
  Rgb sun_irradiance_normal = Rgb::Zero();                      // W m^-2 on a plane facing the sun; 0 = no sun
  Rgb sky_radiance = Rgb::Zero();                               // W m^-2 sr^-1, uniform over the upper hemisphere
};

struct Lighting {
  std::vector<PointLight> point_lights;
  std::vector<AreaLight> area_lights;
  std::vector<SunSky> sun_sky;  // zero or one entry in practice
  bool IsValid(std::string* why) const;
};

}  // namespace relume::radiosity
