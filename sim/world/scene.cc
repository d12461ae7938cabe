#include "sim/world/scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/error.h"

namespace relume::sim {

namespace {
bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}
bool IsFiniteVector(const Eigen::Vector3d& v) {
  return v.allFinite();
}
}  // namespace

const char* ToString(Motion::Type type) {
  switch (type) {
    case Motion::Type::kStatic: return "static";
    case Motion::Type::kLinear: return "linear";
    case Motion::Type::kCircular: return "circular";
    case Motion::Type::kPath: return "path";
  }
  return "?";
}

bool Motion::IsValid(std::string* why) const {
  switch (type) {
    case Type::kStatic: return true;
    case Type::kLinear:
      return IsFiniteVector(velocity_mps) ? true : Fail(why, "linear motion: velocity_mps must be finite");
    case Type::kCircular:
      if (!IsFiniteVector(center)) return Fail(why, "circular motion: center must be finite");
      if (!IsFiniteVector(axis) || axis.norm() < 1e-9)
        return Fail(why, "circular motion: axis must be a non-zero vector");
      if (!(std::isfinite(period_s) && period_s != 0.0)) {
        return Fail(why, "circular motion: period_s must be finite and non-zero (negative turns clockwise)");
      }
      return true;
    case Type::kPath:
      if (waypoints.empty()) return Fail(why, "path motion: needs at least one waypoint");
      for (std::size_t i = 0; i < waypoints.size(); ++i) {
        if (!std::isfinite(waypoints[i].t_s) || !IsFiniteVector(waypoints[i].position)) {
          return Fail(why, "path motion: waypoint times and positions must be finite");
        }
        if (i > 0 && !(waypoints[i].t_s > waypoints[i - 1].t_s)) {
          return Fail(why, "path motion: waypoint times must increase strictly");
        }
      }
      return true;
  }
  return true;
}

Eigen::Vector3d Motion::OffsetAt(UtcTime time, const Eigen::Vector3d& anchor) const {
  const double dt = std::chrono::duration<double>(time - reference_time).count();
  switch (type) {
    case Type::kStatic: return Eigen::Vector3d::Zero();
    case Type::kLinear: return velocity_mps * dt;
    case Type::kCircular: {
      const double angle = 2.0 * std::numbers::pi * dt / period_s;
      const Eigen::AngleAxisd turn(angle, axis.normalized());
      return center + turn * (anchor - center) - anchor;
    }
    case Type::kPath: {
      if (dt <= waypoints.front().t_s) return waypoints.front().position - anchor;
      if (dt >= waypoints.back().t_s) return waypoints.back().position - anchor;
      const auto next = std::upper_bound(waypoints.begin(), waypoints.end(), dt,
                                         [](double t, const Waypoint& w) { return t < w.t_s; });
      const auto prev = next - 1;
      const double f = (dt - prev->t_s) / (next->t_s - prev->t_s);
      return prev->position + f * (next->position - prev->position) - anchor;
    }
  }
  return Eigen::Vector3d::Zero();
}

const char* ToString(SceneObject::Shape shape) {
  switch (shape) {
    case SceneObject::Shape::kPlane: return "plane";
    case SceneObject::Shape::kBox: return "box";
    case SceneObject::Shape::kSphere: return "sphere";
    case SceneObject::Shape::kMesh: return "mesh";
    case SceneObject::Shape::kColorChecker: return "colorchecker";
  }
  return "?";
}

Eigen::Vector3d SceneObject::Anchor() const {
  if (shape == Shape::kSphere || mesh.vertices.empty()) return sphere_center;
  Eigen::Vector3d lo = mesh.vertices.front(), hi = mesh.vertices.front();
  for (const Eigen::Vector3d& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return 0.5 * (lo + hi);
}

bool SceneObject::IsValid(std::string* why) const {
  const std::string prefix = "object '" + name + "': ";
  if (!albedo.allFinite() || albedo.minCoeff() < 0.0 || albedo.maxCoeff() > 1.0) {
    return Fail(why, prefix + "albedo must be in [0, 1] per channel (Lambertian reflectance)");
  }
  std::string reason;
  if (shape == Shape::kSphere) {
    if (!IsFiniteVector(sphere_center)) return Fail(why, prefix + "sphere centre must be finite");
    if (!(std::isfinite(sphere_radius_m) && sphere_radius_m > 0.0)) {
      return Fail(why, prefix + "sphere radius must be positive");
    }
  } else if (!mesh.IsValid(&reason)) {
    return Fail(why, prefix + reason);
  }
  if (!motion.IsValid(&reason)) return Fail(why, prefix + reason);
  return true;
}

TriangleMesh MakeQuad(const Eigen::Vector3d& origin, const Eigen::Vector3d& edge_u, const Eigen::Vector3d& edge_v) {
  TriangleMesh mesh;
  mesh.vertices = {origin, origin + edge_u, origin + edge_u + edge_v, origin + edge_v};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

TriangleMesh MakeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size_m, double yaw_rad) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner(((i & 1) ? 0.5 : -0.5) * size_m.x(), ((i & 2) ? 0.5 : -0.5) * size_m.y(),
                                 ((i & 4) ? 0.5 : -0.5) * size_m.z());
    mesh.vertices.push_back(center + rotation * corner);
  }
  // Outward-facing (counter-clockwise seen from outside).
  mesh.triangles = {{0, 2, 3}, {0, 3, 1},   // bottom (z-)
                    {4, 5, 7}, {4, 7, 6},   // top (z+)
                    {0, 1, 5}, {0, 5, 4},   // south (y-)
                    {2, 6, 7}, {2, 7, 3},   // north (y+)
                    {0, 4, 6}, {0, 6, 2},   // west (x-)
                    {1, 3, 7}, {1, 7, 5}};  // east (x+)
  return mesh;
}

SceneObject MakeColorChecker(const std::string& name, const ColorCheckerGeometry& g,
                             const std::vector<std::string>& patch_names,
                             const std::vector<Eigen::Vector3d>& patch_linear_rgb) {
  RELUME_CHECK(patch_linear_rgb.size() == 24 && patch_names.size() == 24);
  const Eigen::Vector3d n = g.normal.normalized();
  const Eigen::Vector3d up = (g.up - g.up.dot(n) * n).normalized();
  const Eigen::Vector3d right = up.cross(n);  // the viewer's right when facing the chart
  const double pitch = g.patch_size_m + g.gap_m;
  const double width = 6 * g.patch_size_m + 5 * g.gap_m + 2 * g.border_m;
  const double height = 4 * g.patch_size_m + 3 * g.gap_m + 2 * g.border_m;

  SceneObject object;
  object.name = name;
  object.shape = SceneObject::Shape::kColorChecker;
  object.albedo = g.frame_albedo;
  object.mesh = MakeQuad(g.center - 0.5 * width * right - 0.5 * height * up, width * right, height * up);
  object.mesh.face_albedo.assign(2, g.frame_albedo);
  ColorCheckerLayout layout;
  layout.normal_in_world = n;
  layout.patch_size_m = g.patch_size_m;
  for (int row = 0; row < 4; ++row) {
    for (int column = 0; column < 6; ++column) {
      const std::size_t index = static_cast<std::size_t>(row * 6 + column);
      const Eigen::Vector3d albedo = patch_linear_rgb[index].cwiseMax(0.0).cwiseMin(1.0);
      const Eigen::Vector3d center =
          g.center + (column - 2.5) * pitch * right + (1.5 - row) * pitch * up + g.patch_offset_m * n;
      const double h = 0.5 * g.patch_size_m;
      TriangleMesh patch = MakeQuad(center - h * right - h * up, g.patch_size_m * right, g.patch_size_m * up);
      patch.face_albedo.assign(2, albedo);
      object.mesh.Append(patch);
      layout.names.push_back(patch_names[index]);
      layout.albedo.push_back(albedo);
      layout.centers_in_world.push_back(center);
      for (const Eigen::Vector3d& corner :
           {Eigen::Vector3d(center - h * right + h * up), Eigen::Vector3d(center + h * right + h * up),
            Eigen::Vector3d(center + h * right - h * up), Eigen::Vector3d(center - h * right - h * up)}) {
        layout.corners_in_world.push_back(corner);
      }
    }
  }
  object.colorchecker = std::move(layout);
  return object;
}

bool Lamp::IsValid(std::string* why) const {
  const std::string prefix = "lamp '" + name + "': ";
  if (!IsFiniteVector(position)) return Fail(why, prefix + "position must be finite");
  if (!intensity_w_sr.allFinite() || intensity_w_sr.minCoeff() < 0.0) {
    return Fail(why, prefix + "intensity_w_sr must be finite and non-negative");
  }
  if (type == Type::kSpot) {
    if (!IsFiniteVector(direction) || direction.norm() < 1e-9)
      return Fail(why, prefix + "spot direction must be non-zero");
    if (!(cone_half_angle_rad > 0.0 && cone_half_angle_rad <= std::numbers::pi)) {
      return Fail(why, prefix + "cone half-angle must be in (0, 180] deg");
    }
    if (!(falloff_rad >= 0.0 && falloff_rad <= cone_half_angle_rad)) {
      return Fail(why, prefix + "falloff must be in [0, cone half-angle]");
    }
  }
  std::string reason;
  if (!motion.IsValid(&reason)) return Fail(why, prefix + reason);
  return true;
}

double Lamp::SpotFactor(const Eigen::Vector3d& direction_from_lamp) const {
  if (type == Type::kPoint) return 1.0;
  const double angle = std::acos(std::clamp(direction_from_lamp.dot(direction.normalized()), -1.0, 1.0));
  const double inner = cone_half_angle_rad - falloff_rad;
  if (angle <= inner) return 1.0;
  if (angle >= cone_half_angle_rad) return 0.0;
  const double x = (cone_half_angle_rad - angle) / falloff_rad;  // 1 at inner edge, 0 at outer
  return x * x * (3.0 - 2.0 * x);
}

bool RenderOptions::IsValid(std::string* why) const {
  if (sun_samples < 1 || sun_samples > 4096) return Fail(why, "sun_samples must be in [1, 4096]");
  if (sky_samples < 1 || sky_samples > 65536) return Fail(why, "sky_samples must be in [1, 65536]");
  if (indirect_bounces < 0 || indirect_bounces > 16) return Fail(why, "indirect_bounces must be in [0, 16]");
  if (indirect_samples < 1 || indirect_samples > 65536) return Fail(why, "indirect_samples must be in [1, 65536]");
  if (threads < 1 || threads > 256) return Fail(why, "threads must be in [1, 256]");
  return true;
}

bool Scene::IsValid(std::string* why) const {
  std::string reason;
  if (!site.IsValid(&reason)) return Fail(why, "site: " + reason);
  if (objects.empty()) return Fail(why, "the scene has no objects");
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (!objects[i].IsValid(&reason)) return Fail(why, reason);
    for (std::size_t j = 0; j < i; ++j) {
      if (objects[j].name == objects[i].name) return Fail(why, "two objects are named '" + objects[i].name + "'");
    }
  }
  for (const Lamp& lamp : lamps) {
    if (!lamp.IsValid(&reason)) return Fail(why, reason);
  }
  if (!sky.IsValid(&reason)) return Fail(why, reason);
  if (!sun.irradiance_w_m2.allFinite() || sun.irradiance_w_m2.minCoeff() < 0.0) {
    return Fail(why, "sun irradiance must be finite and non-negative");
  }
  if (!(sun.angular_diameter_rad >= 0.0 && sun.angular_diameter_rad < DegToRad(10.0))) {
    return Fail(why, "sun angular diameter must be in [0, 10) deg");
  }
  if (sun.direction_in_enu && (!sun.direction_in_enu->allFinite() || sun.direction_in_enu->norm() < 1e-9)) {
    return Fail(why, "sun direction must be a non-zero vector");
  }
  for (const SceneCamera& camera : cameras) {
    if (!camera.camera.intrinsics.IsValid(&reason)) return Fail(why, "camera '" + camera.name + "': " + reason);
  }
  return render.IsValid(why);
}

void Scene::SetLampPosition(const std::string& lamp_name, const std::string& position_name) {
  std::string lamps_list;
  for (Lamp& lamp : lamps) {
    lamps_list += (lamps_list.empty() ? "" : ", ") + lamp.name;
    if (lamp.name != lamp_name) continue;
    const auto found = lamp.named_positions.find(position_name);
    if (found == lamp.named_positions.end()) {
      std::string names;
      for (const auto& [key, value] : lamp.named_positions) names += (names.empty() ? "" : ", ") + key;
      throw InvalidArgumentError("lamp '" + lamp_name + "' has no position named '" + position_name +
                                 "'; it has: " + (names.empty() ? "none" : names));
    }
    lamp.position = found->second;
    return;
  }
  throw InvalidArgumentError("no lamp named '" + lamp_name +
                             "'; the scene has: " + (lamps_list.empty() ? "none" : lamps_list));
}

int Scene::ObjectIndex(const std::string& object_name) const {
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (objects[i].name == object_name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace relume::sim
