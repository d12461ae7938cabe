#include "processing/radiosity/scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

namespace relume::radiosity {
namespace {

bool Finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

}  // namespace

int Mesh::AddMaterial(const Material& material) {
  materials.push_back(material);
  return static_cast<int>(materials.size()) - 1;
}

void Mesh::AddQuad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& d, int material) {
  const int base = static_cast<int>(geometry.positions.size());
  for (const Eigen::Vector3d* p : {&a, &b, &c, &d}) geometry.positions.push_back(p->cast<float>());
  geometry.triangles.emplace_back(base, base + 1, base + 2);
  geometry.triangles.emplace_back(base, base + 2, base + 3);
  geometry.material.insert(geometry.material.end(), {material, material});
}

void Mesh::AddTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, int material) {
  const int base = static_cast<int>(geometry.positions.size());
  for (const Eigen::Vector3d* p : {&a, &b, &c}) geometry.positions.push_back(p->cast<float>());
  geometry.triangles.emplace_back(base, base + 1, base + 2);
  geometry.material.push_back(material);
}

void Mesh::AddBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int material, bool skip_bottom) {
  const auto p = [&](int x, int y, int z) {
    return Eigen::Vector3d(x ? hi.x() : lo.x(), y ? hi.y() : lo.y(), z ? hi.z() : lo.z());
  };
  AddQuad(p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1), material);  // top, +z
  if (!skip_bottom) AddQuad(p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0), material);
  AddQuad(p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1), material);  // -y
  AddQuad(p(1, 1, 0), p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), material);  // +y
  AddQuad(p(0, 1, 0), p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), material);  // -x
  AddQuad(p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1), material);  // +x
}

void Mesh::AddRoom(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int floor, int ceiling, int walls) {
  const auto p = [&](int x, int y, int z) {
    return Eigen::Vector3d(x ? hi.x() : lo.x(), y ? hi.y() : lo.y(), z ? hi.z() : lo.z());
  };
  AddQuad(p(0, 0, 0), p(1, 0, 0), p(1, 1, 0), p(0, 1, 0), floor);    // normal +z
  AddQuad(p(0, 0, 1), p(0, 1, 1), p(1, 1, 1), p(1, 0, 1), ceiling);  // normal -z
  AddQuad(p(0, 0, 0), p(0, 0, 1), p(1, 0, 1), p(1, 0, 0), walls);    // y = lo, normal +y
  AddQuad(p(1, 1, 0), p(1, 1, 1), p(0, 1, 1), p(0, 1, 0), walls);    // y = hi, normal -y
  AddQuad(p(0, 1, 0), p(0, 1, 1), p(0, 0, 1), p(0, 0, 0), walls);    // x = lo, normal +x
  AddQuad(p(1, 0, 0), p(1, 0, 1), p(1, 1, 1), p(1, 1, 0), walls);    // x = hi, normal -x
}

bool Mesh::IsValid(std::string* why) const {
  if (geometry.triangles.empty()) return Fail(why, "mesh has no triangles");
  if (geometry.material.size() != geometry.triangles.size()) {
    return Fail(why, "geometry.material must have one material id per triangle");
  }
  std::string reason;
  if (!geometry.IsValid(&reason)) return Fail(why, "mesh: " + reason);
  for (size_t m = 0; m < materials.size(); ++m) {
    const Material& mat = materials[m];
    if (!mat.albedo.allFinite() || mat.albedo.minCoeff() < 0.0 || mat.albedo.maxCoeff() > 1.0) {
      return Fail(why, "material '" + mat.name + "': albedo must be in [0, 1] per channel");
    }
    if (!mat.emitted_radiosity.allFinite() || mat.emitted_radiosity.minCoeff() < 0.0) {
      return Fail(why, "material '" + mat.name + "': emitted_radiosity must be finite and >= 0");
    }
  }
  for (int t = 0; t < TriangleCount(); ++t) {
    const int m = geometry.material[static_cast<std::size_t>(t)];
    if (m < 0 || m >= static_cast<int>(materials.size())) {
      return Fail(why, "triangle " + std::to_string(t) + " has a material index out of range");
    }
    const Eigen::Vector3d e1 = Corner(t, 1) - Corner(t, 0);
    const Eigen::Vector3d e2 = Corner(t, 2) - Corner(t, 0);
    const double area = 0.5 * e1.cross(e2).norm();
    const double scale = std::max(e1.squaredNorm(), e2.squaredNorm());
    if (!(area > 1e-12 * scale) || !(area > 0.0)) {
      return Fail(why, "triangle " + std::to_string(t) + " is degenerate (zero area); remove it");
    }
  }
  return true;
}

double PointLight::SpotFactor(const Eigen::Vector3d& direction_from_light) const {
  if (!(spot_direction.norm() > 0.0)) return 1.0;
  const double angle = std::acos(std::clamp(direction_from_light.dot(spot_direction.normalized()), -1.0, 1.0));
  const double inner = cone_half_angle_rad - falloff_rad;
  if (angle <= inner) return 1.0;
  if (angle >= cone_half_angle_rad) return 0.0;
  const double x = (cone_half_angle_rad - angle) / falloff_rad;  // 1 at the inner edge, 0 at the cone
  return x * x * (3.0 - 2.0 * x);
}

bool Lighting::IsValid(std::string* why) const {
  for (const auto& light : point_lights) {
    if (!Finite(light.position_m) || !light.intensity_w_per_sr.allFinite() ||
        light.intensity_w_per_sr.minCoeff() < 0.0) {
      return Fail(why, "point light: position and intensity must be finite, intensity >= 0");
    }
    if (!Finite(light.spot_direction) || !std::isfinite(light.cone_half_angle_rad) ||
        !std::isfinite(light.falloff_rad)) {
      return Fail(why, "point light: spot direction and angles must be finite");
    }
    if (light.spot_direction.norm() > 0.0 &&
        !(light.cone_half_angle_rad > 0.0 && light.falloff_rad >= 0.0 &&
          light.falloff_rad <= light.cone_half_angle_rad && light.cone_half_angle_rad < std::numbers::pi)) {
      return Fail(why, "spot light: need 0 < cone_half_angle_rad < pi and 0 <= falloff_rad <= cone_half_angle_rad");
    }
  }
  for (const auto& light : area_lights) {
    if (!Finite(light.corner_m) || !Finite(light.edge_u_m) || !Finite(light.edge_v_m) || !light.radiance.allFinite() ||
        light.radiance.minCoeff() < 0.0) {
      return Fail(why, "area light: geometry and radiance must be finite, radiance >= 0");
    }
    if (!(light.edge_u_m.cross(light.edge_v_m).norm() > 0.0)) {
      return Fail(why, "area light: edges are parallel or zero (no area)");
    }
  }
  for (const auto& sky : sun_sky) {
    if (!Finite(sky.sun_dir_in_scene) || std::abs(sky.sun_dir_in_scene.norm() - 1.0) > 1e-6) {
      return Fail(why, "sun_dir_in_scene must be a unit vector");
    }
    if (!sky.sun_irradiance_normal.allFinite() || sky.sun_irradiance_normal.minCoeff() < 0.0 ||
        !sky.sky_radiance.allFinite() || sky.sky_radiance.minCoeff() < 0.0) {
      return Fail(why, "sun irradiance and sky radiance must be finite and >= 0");
    }
  }
  return true;
}

}  // namespace relume::radiosity
