#include "pipeline/radiosity_scene.h"

#include <algorithm>
#include <limits>
#include <map>
#include <sstream>

#include "core/error.h"

namespace relume::pipeline {

namespace {

// Barycentric coordinates of p (projected onto the triangle's plane); min() >= 0 inside.
Eigen::Vector3d Barycentric(const radiosity::Triangle& t, const Eigen::Vector3d& p) {
  const Eigen::Vector3d e1 = t.v1 - t.v0, e2 = t.v2 - t.v0, d = p - t.v0;
  const double a = e1.dot(e1), b = e1.dot(e2), c = e2.dot(e2);
  const double p1 = d.dot(e1), p2 = d.dot(e2);
  const double det = a * c - b * b;
  const double v = (c * p1 - b * p2) / det;
  const double w = (a * p2 - b * p1) / det;
  return {1.0 - v - w, v, w};
}

}  // namespace

RadiosityScene RadiositySceneFromModel(const SceneModel& model, const std::string& material_groups) {
  RadiosityScene out;
  // Group name per object ("" = its own material).
  std::vector<std::string> group(model.objects.size());
  std::stringstream groups(material_groups);
  std::string one;
  while (std::getline(groups, one, ',')) {
    if (one.empty()) continue;
    std::stringstream members(one);
    std::string name;
    while (std::getline(members, name, '+')) {
      const int index = model.ObjectIndex(name);
      if (index < 0) {
        std::string names;
        for (const SceneModelObject& o : model.objects) names += (names.empty() ? "" : ", ") + o.name;
        throw InvalidArgumentError("--set material_groups=" + material_groups + ": no scene object '" + name +
                                   "' (the scene model has " + names + ")");
      }
      group[index] = one;
    }
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const SceneModelObject& object : model.objects) {
    if (object.kind == SceneModelObject::Kind::kSphere) {
      throw InvalidArgumentError("scene object '" + object.name +
                                 "' is a sphere; the radiosity pipeline takes surfaces and solids given as triangles "
                                 "(give it as a mesh)");
    }
    for (const Eigen::Vector3d& v : object.vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  }
  if (!(lo.allFinite() && hi.allFinite())) throw InvalidArgumentError("the scene model has no geometry for radiosity");
  const Eigen::Vector3d scene_center = 0.5 * (lo + hi);
  const double floor_z = lo.z();

  // One radiosity material per (object or group, scene model material when the object's faces
  // carry several).
  std::map<std::pair<std::string, int>, int> material_of;
  auto material_for = [&](int o, int model_material, bool split) {
    const SceneModelObject& object = model.objects[o];
    const std::string base_name = group[o].empty() ? object.name : group[o];
    const bool known_index = model_material >= 0 && model_material < static_cast<int>(model.materials.size());
    const std::pair<std::string, int> key(base_name, split ? model_material : -1);
    if (const auto it = material_of.find(key); it != material_of.end()) return it->second;
    const std::string name = split && known_index ? model.materials[model_material].name : base_name;
    const int material = out.mesh.AddMaterial({name, radiosity::Rgb::Constant(0.5), radiosity::Rgb::Zero()});
    std::optional<Eigen::Vector3d> known;
    if (known_index && (split || group[o].empty())) known = model.materials[model_material].albedo;
    out.known_albedo.push_back(known);
    material_of[key] = material;
    return material;
  };
  for (int o = 0; o < static_cast<int>(model.objects.size()); ++o) {
    const SceneModelObject& object = model.objects[o];
    const bool split =
        !object.face_material.empty() && std::any_of(object.face_material.begin(), object.face_material.end(),
                                                     [&](int m) { return m != object.face_material.front(); });
    auto face_material = [&](std::size_t f) {
      if (f < object.face_material.size()) return object.face_material[f];
      return object.material;
    };
    out.object_material.push_back(material_for(o, face_material(0), split));
    Eigen::Vector3d object_lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d object_hi = -object_lo;
    for (const Eigen::Vector3d& v : object.vertices) {
      object_lo = object_lo.cwiseMin(v);
      object_hi = object_hi.cwiseMax(v);
    }
    const bool surface = object.kind == SceneModelObject::Kind::kSurface;
    const Eigen::Vector3d object_center = 0.5 * (object_lo + object_hi);
    TriangleMesh& geometry = out.mesh.geometry;
    const int base = static_cast<int>(geometry.positions.size());
    const int triangles_before = out.mesh.TriangleCount();
    for (const Eigen::Vector3d& v : object.vertices) geometry.positions.push_back(v.cast<float>());
    for (std::size_t f = 0; f < object.triangles.size(); ++f) {
      const Eigen::Vector3i& tri = object.triangles[f];
      const Eigen::Vector3d& a = object.vertices[tri[0]];
      const Eigen::Vector3d& b = object.vertices[tri[1]];
      const Eigen::Vector3d& c = object.vertices[tri[2]];
      const Eigen::Vector3d normal = (b - a).cross(c - a);
      if (!(normal.norm() > 0.0)) continue;  // degenerate: nothing to light
      const Eigen::Vector3d centroid = (a + b + c) / 3.0;
      const Eigen::Vector3d toward =
          surface ? Eigen::Vector3d(scene_center - centroid) : Eigen::Vector3d(centroid - object_center);
      const bool flip = normal.dot(toward) < 0.0;
      const Eigen::Vector3d facing = flip ? Eigen::Vector3d(-normal) : normal;
      if (!surface && facing.normalized().z() < -0.99 && std::max({a.z(), b.z(), c.z()}) <= floor_z + 1e-3) continue;
      geometry.triangles.push_back(Eigen::Vector3i::Constant(base) +
                                   (flip ? Eigen::Vector3i(tri[0], tri[2], tri[1]) : tri));
      geometry.material.push_back(material_for(o, face_material(f), split));
      out.triangle_object.push_back(o);
      out.triangle_face.push_back(static_cast<int>(f));
    }
    out.object_triangles.push_back(out.mesh.TriangleCount() - triangles_before);
  }
  return out;
}

radiosity::Lighting LightingAt(const SceneModel& model, UtcTime utc) {
  radiosity::Lighting lighting;
  for (const SceneModelLamp& lamp : model.lamps) {
    radiosity::PointLight light;
    light.position_m = lamp.PositionAt(utc);
    light.intensity_w_per_sr = lamp.intensity_w_sr;
    if (lamp.type == SceneModelLamp::Type::kSpot) {
      light.spot_direction = lamp.direction.normalized();
      light.cone_half_angle_rad = lamp.cone_half_angle_rad;
      light.falloff_rad = lamp.falloff_rad;
    }
    lighting.point_lights.push_back(light);
  }
  return lighting;
}

int PatchAt(const radiosity::PatchHierarchy& hierarchy, int triangle, const Eigen::Vector3d& p) {
  int node = hierarchy.roots()[triangle];
  while (!hierarchy.nodes()[node].IsLeaf()) {
    const int first = hierarchy.nodes()[node].first_child;
    int best = first;
    double best_inside = -std::numeric_limits<double>::infinity();
    for (int c = first; c < first + 4; ++c) {
      const double inside = Barycentric(hierarchy.nodes()[c].triangle, p).minCoeff();
      if (inside > best_inside) {
        best_inside = inside;
        best = c;
      }
    }
    node = best;
  }
  return hierarchy.nodes()[node].leaf;
}

cv::Mat PatchIdImage(const radiosity::PatchHierarchy& hierarchy, const RayCaster& caster, const PinholeCamera& camera,
                     cv::Mat* points_m) {
  const int width = camera.intrinsics.width, height = camera.intrinsics.height;
  cv::Mat ids(height, width, CV_32SC1, cv::Scalar(-1));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (points_m != nullptr) *points_m = cv::Mat(height, width, CV_32FC3, cv::Scalar(nan, nan, nan));
  const Eigen::Matrix3d rotation = camera.world_from_camera.linear();
  const Eigen::Vector3d eye = camera.world_from_camera.translation();
  for (int v = 0; v < height; ++v) {
    int* row = ids.ptr<int>(v);
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d dir = (rotation * camera.intrinsics.Unproject({u + 0.5, v + 0.5})).normalized();
      const RayCaster::Hit hit =
          caster.Intersect(eye.cast<float>(), dir.cast<float>(), 0.0f, std::numeric_limits<float>::infinity());
      if (!hit.valid) continue;
      const double t = hit.t;
      const int patch = PatchAt(hierarchy, hit.triangle, eye + t * dir);
      if (hierarchy.leaf(patch).normal.dot(dir) >= 0.0) continue;  // the back of a one-sided patch
      row[u] = patch;
      if (points_m != nullptr) {
        const Eigen::Vector3d x = eye + t * dir;
        points_m->at<cv::Vec3f>(v, u) =
            cv::Vec3f(static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z()));
      }
    }
  }
  return ids;
}

}  // namespace relume::pipeline
