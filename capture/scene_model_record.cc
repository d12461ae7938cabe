#include "capture/scene_model_record.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "capture/session.h"
#include "core/error.h"

namespace relume::capture {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

nlohmann::json Vec(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

// j[key] as a string, "" when absent (json::value with a string default trips GCC's -Wnull-dereference).
std::string StringOr(const nlohmann::json& j, const char* key) {
  return j.contains(key) ? j.at(key).get<std::string>() : std::string();
}

Eigen::Vector3d VecFrom(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw std::invalid_argument("expected [x, y, z]");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

nlohmann::json CameraJson(const SceneModelCamera& c) {
  const PinholeIntrinsics& k = c.camera.intrinsics;
  std::vector<double> pose;
  const Eigen::Matrix4d m = c.camera.world_from_camera.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) pose.push_back(m(r, col));
  }
  return {{"device_id", c.device_id},
          {"width", k.width},
          {"height", k.height},
          {"fx", k.fx},
          {"fy", k.fy},
          {"cx", k.cx},
          {"cy", k.cy},
          {"world_from_camera", pose},
          {"distortion", c.distortion},
          {"source", c.source},
          {"reprojection_error_px", c.reprojection_error_px}};
}

SceneModelCamera CameraFrom(const nlohmann::json& j) {
  SceneModelCamera c;
  c.device_id = j.at("device_id").get<std::string>();
  PinholeIntrinsics& k = c.camera.intrinsics;
  k.width = j.at("width").get<int>();
  k.height = j.at("height").get<int>();
  k.fx = j.at("fx").get<double>();
  k.fy = j.at("fy").get<double>();
  k.cx = j.at("cx").get<double>();
  k.cy = j.at("cy").get<double>();
  const std::vector<double> pose = j.at("world_from_camera").get<std::vector<double>>();
  if (pose.size() != 16) throw std::invalid_argument("world_from_camera needs 16 numbers");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) m(r, col) = pose[static_cast<std::size_t>(4 * r + col)];
  }
  c.camera.world_from_camera.matrix() = m;
  c.distortion = j.value("distortion", std::vector<double>{});
  c.source = StringOr(j, "source");
  c.reprojection_error_px = j.value("reprojection_error_px", -1.0);
  return c;
}

nlohmann::json ObjectJson(const SceneModelObject& o) {
  std::vector<double> vertices;
  vertices.reserve(3 * o.vertices.size());
  for (const Eigen::Vector3d& v : o.vertices) vertices.insert(vertices.end(), {v.x(), v.y(), v.z()});
  std::vector<int> triangles;
  triangles.reserve(3 * o.triangles.size());
  for (const Eigen::Vector3i& t : o.triangles) triangles.insert(triangles.end(), {t[0], t[1], t[2]});
  nlohmann::json j = {{"name", o.name}, {"kind", ToString(o.kind)}};
  if (o.kind == SceneModelObject::Kind::kSphere) {
    j["sphere_center"] = Vec(o.sphere_center);
    j["sphere_radius_m"] = o.sphere_radius_m;
    j["material"] = o.material;
  } else {
    j["vertices"] = vertices;
    j["triangles"] = triangles;
    j["face_material"] = o.face_material;
  }
  return j;
}

SceneModelObject ObjectFrom(const nlohmann::json& j) {
  SceneModelObject o;
  o.name = j.at("name").get<std::string>();
  o.kind = SceneModelObjectKindFromString(j.at("kind").get<std::string>());
  if (o.kind == SceneModelObject::Kind::kSphere) {
    o.sphere_center = VecFrom(j.at("sphere_center"));
    o.sphere_radius_m = j.at("sphere_radius_m").get<double>();
    o.material = j.at("material").get<int>();
    return o;
  }
  const std::vector<double> vertices = j.at("vertices").get<std::vector<double>>();
  const std::vector<int> triangles = j.at("triangles").get<std::vector<int>>();
  if (vertices.size() % 3 != 0 || triangles.size() % 3 != 0) {
    throw std::invalid_argument("object '" + o.name + "': vertices and triangles need triples");
  }
  for (std::size_t i = 0; i < vertices.size(); i += 3)
    o.vertices.emplace_back(vertices[i], vertices[i + 1], vertices[i + 2]);
  for (std::size_t i = 0; i < triangles.size(); i += 3) {
    o.triangles.emplace_back(triangles[i], triangles[i + 1], triangles[i + 2]);
  }
  o.face_material = j.at("face_material").get<std::vector<int>>();
  return o;
}

nlohmann::json LampJson(const SceneModelLamp& l) {
  nlohmann::json track = nlohmann::json::array();
  for (const LampPose& pose : l.track) {
    track.push_back({{"utc_ns", pose.utc.time_since_epoch().count()},
                     {"utc", FormatIso8601(pose.utc, std::chrono::seconds{0}, 3)},
                     {"position", Vec(pose.position)}});
  }
  return {{"name", l.name},
          {"type", l.type == SceneModelLamp::Type::kSpot ? "spot" : "point"},
          {"intensity_w_sr", Vec(l.intensity_w_sr)},
          {"direction", Vec(l.direction)},
          {"cone_half_angle_deg", l.cone_half_angle_rad / kDeg},
          {"falloff_deg", l.falloff_rad / kDeg},
          {"track", track}};
}

SceneModelLamp LampFrom(const nlohmann::json& j) {
  SceneModelLamp l;
  l.name = j.at("name").get<std::string>();
  const std::string type = j.at("type").get<std::string>();
  if (type != "point" && type != "spot") throw std::invalid_argument("lamp type '" + type + "'");
  l.type = type == "spot" ? SceneModelLamp::Type::kSpot : SceneModelLamp::Type::kPoint;
  l.intensity_w_sr = VecFrom(j.at("intensity_w_sr"));
  l.direction = VecFrom(j.at("direction"));
  l.cone_half_angle_rad = j.at("cone_half_angle_deg").get<double>() * kDeg;
  l.falloff_rad = j.at("falloff_deg").get<double>() * kDeg;
  for (const nlohmann::json& pose : j.at("track")) {
    l.track.push_back({UtcTime(Nanoseconds(pose.at("utc_ns").get<std::int64_t>())), VecFrom(pose.at("position"))});
  }
  return l;
}

}  // namespace

std::string SceneModelToJson(const SceneModel& model) {
  nlohmann::json j = {{"version", SceneModel::kVersion},
                      {"source", model.source},
                      {"site",
                       {{"latitude_deg", model.site.latitude_deg()},
                        {"longitude_deg", model.site.longitude_deg()},
                        {"height_m", model.site.height_m}}}};
  j["cameras"] = nlohmann::json::array();
  for (const SceneModelCamera& c : model.cameras) j["cameras"].push_back(CameraJson(c));
  j["materials"] = nlohmann::json::array();
  for (const SceneModelMaterial& m : model.materials) {
    nlohmann::json mj = {{"name", m.name}};
    if (m.albedo) mj["albedo"] = Vec(*m.albedo);
    j["materials"].push_back(mj);
  }
  j["objects"] = nlohmann::json::array();
  for (const SceneModelObject& o : model.objects) j["objects"].push_back(ObjectJson(o));
  j["lamps"] = nlohmann::json::array();
  for (const SceneModelLamp& l : model.lamps) j["lamps"].push_back(LampJson(l));
  return j.dump();
}

SceneModel SceneModelFromJson(const std::string& json, const std::string& what) {
  SceneModel model;
  int version = 0;
  try {
    const nlohmann::json j = nlohmann::json::parse(json);
    version = j.at("version").get<int>();
    if (version > SceneModel::kVersion) {
      throw ConfigError(what, 0, "version",
                        "the scene model has version " + std::to_string(version) + "; this relume reads up to " +
                            std::to_string(SceneModel::kVersion) + " (a newer relume wrote it: update relume)");
    }
    model.source = StringOr(j, "source");
    const nlohmann::json& site = j.at("site");
    model.site = Site::FromDegrees(site.at("latitude_deg").get<double>(), site.at("longitude_deg").get<double>(),
                                   site.at("height_m").get<double>());
    for (const nlohmann::json& c : j.at("cameras")) model.cameras.push_back(CameraFrom(c));
    for (const nlohmann::json& m : j.at("materials")) {
      SceneModelMaterial material{m.at("name").get<std::string>(), std::nullopt};
      if (m.contains("albedo")) material.albedo = VecFrom(m.at("albedo"));
      model.materials.push_back(material);
    }
    for (const nlohmann::json& o : j.at("objects")) model.objects.push_back(ObjectFrom(o));
    for (const nlohmann::json& l : j.at("lamps")) model.lamps.push_back(LampFrom(l));
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw IoError(what, std::string("is not a scene model: ") + e.what());
  }
  std::string why;
  if (!model.IsValid(&why)) throw IoError(what, "the scene model is invalid: " + why);
  return model;
}

std::int64_t StoreSceneModel(const std::filesystem::path& session_dir, const SceneModel& model) {
  std::string why;
  if (!model.IsValid(&why)) throw InvalidArgumentError("the scene model for " + session_dir.string() + ": " + why);
  CalibrationRecord record;
  record.created_utc = UtcNow();
  record.kind = kSceneModelKind;
  record.json = SceneModelToJson(model);
  return SessionWriter::Append(session_dir)->AddCalibration(record);
}

const CalibrationRecord* LatestSceneModelRow(const std::vector<CalibrationRecord>& rows) {
  const CalibrationRecord* latest = nullptr;
  for (const CalibrationRecord& row : rows) {
    if (row.kind == kSceneModelKind) latest = &row;
  }
  return latest;
}

std::string DescribeSceneModel(const SceneModel& model) {
  int known = 0;
  for (const SceneModelMaterial& m : model.materials) known += m.albedo ? 1 : 0;
  std::ostringstream out;
  out << model.cameras.size() << (model.cameras.size() == 1 ? " camera, " : " cameras, ") << model.objects.size()
      << (model.objects.size() == 1 ? " object (" : " objects (") << model.TriangleCount() << " triangles), "
      << model.materials.size() << " materials (" << known << " with known albedo), " << model.lamps.size()
      << (model.lamps.size() == 1 ? " lamp" : " lamps");
  return out.str();
}

}  // namespace relume::capture
