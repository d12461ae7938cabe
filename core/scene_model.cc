#include "core/scene_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "core/error.h"

namespace relume {

namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return false;
}

bool Finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

}  // namespace

const char* ToString(SceneModelObject::Kind kind) {
  switch (kind) {
    case SceneModelObject::Kind::kSurface: return "surface";
    case SceneModelObject::Kind::kSolid: return "solid";
    case SceneModelObject::Kind::kSphere: return "sphere";
  }
  return "?";
}

SceneModelObject::Kind SceneModelObjectKindFromString(const std::string& text) {
  if (text == "surface") return SceneModelObject::Kind::kSurface;
  if (text == "solid") return SceneModelObject::Kind::kSolid;
  if (text == "sphere") return SceneModelObject::Kind::kSphere;
  throw InvalidArgumentError("scene object kind '" + text + "' is not one of surface, solid, sphere");
}

bool SceneModelCamera::IsValid(std::string* why) const {
  if (device_id.empty()) return Fail(why, "a camera has no device id");
  std::string reason;
  if (!camera.intrinsics.IsValid(&reason)) return Fail(why, "camera " + device_id + ": " + reason);
  if (!camera.world_from_camera.matrix().allFinite()) return Fail(why, "camera " + device_id + ": pose is not finite");
  const Eigen::Matrix3d r = camera.world_from_camera.linear();
  if (!(r.transpose() * r).isIdentity(1e-6) || !(r.determinant() > 0.0)) {
    return Fail(why, "camera " + device_id + ": world_from_camera's rotation is not a rotation");
  }
  if (!distortion.empty() && distortion.size() != 4 && distortion.size() != 5 && distortion.size() != 8) {
    return Fail(why, "camera " + device_id + ": distortion has " + std::to_string(distortion.size()) +
                         " coefficients (OpenCV's model takes 4, 5 or 8)");
  }
  for (double d : distortion) {
    if (!std::isfinite(d)) return Fail(why, "camera " + device_id + ": a distortion coefficient is not finite");
  }
  return true;
}

bool SceneModelLamp::IsValid(std::string* why) const {
  const std::string what = "lamp '" + name + "'";
  if (name.empty()) return Fail(why, "a lamp has no name");
  if (!Finite(intensity_w_sr) || intensity_w_sr.minCoeff() < 0.0) {
    return Fail(why, what + ": intensity must be finite and >= 0 W/sr");
  }
  if (track.empty()) return Fail(why, what + ": its track has no position");
  for (std::size_t i = 0; i < track.size(); ++i) {
    if (!Finite(track[i].position)) return Fail(why, what + ": track position " + std::to_string(i) + " is not finite");
    if (i > 0 && track[i].utc < track[i - 1].utc) return Fail(why, what + ": track times are not in order");
  }
  if (type == Type::kSpot) {
    if (!Finite(direction) || !(direction.norm() > 0.0)) return Fail(why, what + ": spot direction is zero");
    if (!(cone_half_angle_rad > 0.0 && cone_half_angle_rad < std::numbers::pi)) {
      return Fail(why, what + ": cone half angle must be in (0, 180) deg");
    }
    if (!(falloff_rad >= 0.0 && falloff_rad <= cone_half_angle_rad)) {
      return Fail(why, what + ": falloff must be in [0, cone half angle]");
    }
  }
  return true;
}

Eigen::Vector3d SceneModelLamp::PositionAt(UtcTime utc) const {
  RELUME_CHECK(!track.empty());
  if (utc <= track.front().utc) return track.front().position;
  if (utc >= track.back().utc) return track.back().position;
  const auto after =
      std::upper_bound(track.begin(), track.end(), utc, [](UtcTime t, const LampPose& pose) { return t < pose.utc; });
  const LampPose& b = *after;
  const LampPose& a = *(after - 1);
  const double span = std::chrono::duration<double>(b.utc - a.utc).count();
  if (!(span > 0.0)) return b.position;
  const double f = std::chrono::duration<double>(utc - a.utc).count() / span;
  return a.position + f * (b.position - a.position);
}

bool SceneModel::IsValid(std::string* why) const {
  std::string reason;
  if (!site.IsValid(&reason)) return Fail(why, "site: " + reason);
  std::set<std::string> devices;
  for (const SceneModelCamera& camera : cameras) {
    if (!camera.IsValid(why)) return false;
    if (!devices.insert(camera.device_id).second) return Fail(why, "two cameras for device " + camera.device_id);
  }
  for (const SceneModelMaterial& material : materials) {
    if (material.name.empty()) return Fail(why, "a material has no name");
    if (material.albedo &&
        (!Finite(*material.albedo) || material.albedo->minCoeff() < 0.0 || material.albedo->maxCoeff() > 1.0)) {
      return Fail(why, "material '" + material.name + "': albedo must be in [0, 1]");
    }
  }
  const int material_count = static_cast<int>(materials.size());
  std::set<std::string> names;
  for (const SceneModelObject& object : objects) {
    const std::string what = "object '" + object.name + "'";
    if (object.name.empty()) return Fail(why, "an object has no name");
    if (!names.insert(object.name).second) return Fail(why, "two objects named '" + object.name + "'");
    if (object.kind == SceneModelObject::Kind::kSphere) {
      if (!Finite(object.sphere_center) || !(object.sphere_radius_m > 0.0)) {
        return Fail(why, what + ": a sphere needs a finite centre and a radius > 0");
      }
      if (object.material < 0 || object.material >= material_count) {
        return Fail(why, what + ": material index " + std::to_string(object.material) + " is out of range");
      }
      continue;
    }
    if (object.triangles.empty()) return Fail(why, what + " has no triangles");
    if (object.face_material.size() != object.triangles.size()) {
      return Fail(why, what + ": " + std::to_string(object.face_material.size()) + " face materials for " +
                           std::to_string(object.triangles.size()) + " triangles");
    }
    const int n = static_cast<int>(object.vertices.size());
    for (const Eigen::Vector3d& v : object.vertices) {
      if (!Finite(v)) return Fail(why, what + ": a vertex is not finite");
    }
    for (const Eigen::Vector3i& t : object.triangles) {
      if (t.minCoeff() < 0 || t.maxCoeff() >= n) return Fail(why, what + ": a triangle's vertex index is out of range");
    }
    for (int m : object.face_material) {
      if (m < 0 || m >= material_count) {
        return Fail(why, what + ": face material index " + std::to_string(m) + " is out of range");
      }
    }
  }
  std::set<std::string> lamp_names;
  for (const SceneModelLamp& lamp : lamps) {
    if (!lamp.IsValid(why)) return false;
    if (!lamp_names.insert(lamp.name).second) return Fail(why, "two lamps named '" + lamp.name + "'");
  }
  return true;
}

const SceneModelCamera* SceneModel::FindCamera(const std::string& device_id) const {
  for (const SceneModelCamera& camera : cameras) {
    if (camera.device_id == device_id) return &camera;
  }
  // "dslr" for "sim:dslr" and the other way round: the part after the backend's prefix.
  const auto bare = [](const std::string& id) {
    const std::size_t colon = id.find(':');
    return colon == std::string::npos ? id : id.substr(colon + 1);
  };
  const SceneModelCamera* found = nullptr;
  for (const SceneModelCamera& camera : cameras) {
    if (bare(camera.device_id) == bare(device_id)) {
      if (found != nullptr) return nullptr;  // ambiguous: two backends with one id
      found = &camera;
    }
  }
  return found;
}

int SceneModel::ObjectIndex(const std::string& name) const {
  for (int i = 0; i < static_cast<int>(objects.size()); ++i) {
    if (objects[i].name == name) return i;
  }
  return -1;
}

std::size_t SceneModel::TriangleCount() const {
  std::size_t n = 0;
  for (const SceneModelObject& object : objects) n += object.triangles.size();
  return n;
}

}  // namespace relume
