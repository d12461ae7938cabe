#include "core/scene_model_file.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>

#include "core/error.h"
#include "core/frames.h"
#include "core/mesh_io.h"
#include "core/yaml_file.h"

namespace relume {

namespace {

namespace fs = std::filesystem;

constexpr double kDeg = std::numbers::pi / 180.0;

// root[key] as a list (empty when absent); ConfigError when it is something else.
YAML::Node OptionalList(const YamlFile& file, const YAML::Node& map, const std::string& key) {
  const YAML::Node v = map[key];
  if (!v.IsDefined() || v.IsNull()) return YAML::Node(YAML::NodeType::Sequence);
  if (!v.IsSequence()) file.Fail(v, key, "expected a list");
  return v;
}

Eigen::Vector3d RequireVec3(const YamlFile& file, const YAML::Node& map, const std::string& key) {
  const YAML::Node v = map[key];
  if (!v.IsDefined() || v.IsNull()) file.Fail(map, key, "missing; expected [x, y, z]");
  if (!v.IsSequence() || v.size() != 3) file.Fail(v, key, "expected three numbers [x, y, z]");
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) {
    YAML::Node wrap;
    wrap["x"] = v[static_cast<std::size_t>(i)];
    out[i] = file.RequireDouble(wrap, "x");
  }
  if (!out.allFinite()) file.Fail(v, key, "expected finite numbers");
  return out;
}

std::vector<double> RequireNumbers(const YamlFile& file, const YAML::Node& map, const std::string& key) {
  const YAML::Node v = map[key];
  if (!v.IsSequence()) file.Fail(map, key, "expected a list of numbers");
  std::vector<double> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    YAML::Node wrap;
    wrap["x"] = v[i];
    out.push_back(file.RequireDouble(wrap, "x"));
  }
  return out;
}

// Positions and directions of the file's frame, in ENU at the model's site.
class FileFrame {
 public:
  FileFrame(const Site& site, bool utm, std::optional<int> zone) : enu_(site) {
    if (utm) grid_.emplace(site, zone);
  }
  Eigen::Vector3d Point(const Eigen::Vector3d& p) const {
    return grid_ ? enu_.EnuFromGeodetic(grid_->GeodeticFromGrid(p)) : p;
  }
  Eigen::Vector3d Direction(const Eigen::Vector3d& d) const { return grid_ ? grid_->EnuFromGridDirection(d) : d; }
  std::string Name() const { return grid_ ? "UTM zone " + std::to_string(grid_->zone()) : "ENU"; }

 private:
  EnuFrame enu_;
  std::optional<UtmGridFrame> grid_;
};

// The entry's own `frame:` when it gives one, else the file's.
const FileFrame& EntryFrame(const YamlFile& file, const YAML::Node& node, const FileFrame& file_frame,
                            const FileFrame& enu, const std::optional<FileFrame>& utm) {
  if (!node["frame"]) return file_frame;
  const std::string name = file.RequireString(node, "frame");
  if (name != "enu" && name != "utm") file.Fail(node["frame"], "frame", "expected enu or utm");
  if (name == "enu") return enu;
  if (!utm) file.Fail(node["frame"], "frame", "the site is outside UTM's latitude band (84 N .. 80 S)");
  return *utm;
}

SceneModelCamera ReadCamera(const YamlFile& file, const YAML::Node& node, const FileFrame& frame) {
  file.RejectUnknownKeys(node, {"device", "intrinsics", "distortion", "position_m", "look_at_m", "up",
                                "world_from_camera", "reprojection_error_px", "source", "frame"});
  SceneModelCamera camera;
  camera.device_id = file.RequireString(node, "device");
  const YAML::Node k = node["intrinsics"];
  if (!k.IsMap())
    file.Fail(node, "intrinsics", "expected {width, height, fx, fy, cx, cy} or {width, height, horizontal_fov_deg}");
  const int width = file.RequireInt(k, "width", 1, 1 << 16);
  const int height = file.RequireInt(k, "height", 1, 1 << 16);
  if (k["horizontal_fov_deg"]) {
    file.RejectUnknownKeys(k, {"width", "height", "horizontal_fov_deg"});
    const double fov = file.RequireDouble(k, "horizontal_fov_deg");
    if (!(fov > 0.0 && fov < 180.0)) file.Fail(k, "horizontal_fov_deg", "must be in (0, 180)");
    camera.camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, fov * kDeg);
  } else {
    file.RejectUnknownKeys(k, {"width", "height", "fx", "fy", "cx", "cy"});
    camera.camera.intrinsics = {width,
                                height,
                                file.RequireDouble(k, "fx"),
                                file.RequireDouble(k, "fy"),
                                file.RequireDouble(k, "cx"),
                                file.RequireDouble(k, "cy")};
  }
  if (node["distortion"]) camera.distortion = RequireNumbers(file, node, "distortion");
  if (node["world_from_camera"]) {
    if (node["position_m"] || node["look_at_m"]) {
      file.Fail(node, "world_from_camera", "give either world_from_camera or position_m with look_at_m, not both");
    }
    const std::vector<double> m = RequireNumbers(file, node, "world_from_camera");
    if (m.size() != 16)
      file.Fail(node["world_from_camera"], "world_from_camera", "expected 16 numbers (row-major 4x4)");
    Eigen::Matrix3d r;
    Eigen::Vector3d t;
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) r(row, col) = m[static_cast<std::size_t>(4 * row + col)];
      t[row] = m[static_cast<std::size_t>(4 * row + 3)];
    }
    for (int col = 0; col < 3; ++col) r.col(col) = frame.Direction(r.col(col));
    camera.camera.world_from_camera.linear() = r;
    camera.camera.world_from_camera.translation() = frame.Point(t);
  } else {
    const Eigen::Vector3d eye = frame.Point(RequireVec3(file, node, "position_m"));
    const Eigen::Vector3d target = frame.Point(RequireVec3(file, node, "look_at_m"));
    const Eigen::Vector3d up = node["up"] ? frame.Direction(RequireVec3(file, node, "up")) : Eigen::Vector3d::UnitZ();
    if (!((target - eye).norm() > 0.0)) file.Fail(node, "look_at_m", "must differ from position_m");
    if (!((target - eye).normalized().cross(up.normalized()).norm() > 1e-6)) {
      file.Fail(node, "up", "must not be parallel to the viewing direction (give `up`)");
    }
    camera.camera = PinholeCamera::LookAt(camera.camera.intrinsics, eye, target, up);
  }
  if (node["reprojection_error_px"]) camera.reprojection_error_px = file.RequireDouble(node, "reprojection_error_px");
  camera.source = node["source"] ? file.RequireString(node, "source")
                                 : "scene model file " + file.path() + " (" + frame.Name() + ")";
  std::string why;
  if (!camera.IsValid(&why)) file.Fail(node, "device", why);
  return camera;
}

int AddMaterial(SceneModel* model, const std::string& name) {
  for (int i = 0; i < static_cast<int>(model->materials.size()); ++i) {
    if (model->materials[static_cast<std::size_t>(i)].name == name) return i;
  }
  model->materials.push_back({name, std::nullopt});
  return static_cast<int>(model->materials.size()) - 1;
}

// The mesh's triangles and vertices (+ offset, through `frame` into ENU), its faces' materials:
// `own`, or one per OBJ usemtl group.
void FillMeshObject(const MeshData& mesh, const FileFrame& frame, const Eigen::Vector3d& offset, int own,
                    SceneModel* model, SceneModelObject* object) {
  for (const Eigen::Vector3d& v : mesh.vertices) object->vertices.push_back(frame.Point(v + offset));
  object->triangles = mesh.triangles;
  object->face_material.assign(object->triangles.size(), own);
  for (std::size_t f = 0; f < mesh.face_material.size() && f < object->triangles.size(); ++f) {
    if (!mesh.face_material[f].empty())
      object->face_material[f] = AddMaterial(model, object->name + "/" + mesh.face_material[f]);
  }
}

SceneModelObject ReadObject(const YamlFile& file, const YAML::Node& node, const FileFrame& frame, SceneModel* model) {
  file.RejectUnknownKeys(node, {"name", "kind", "mesh", "offset", "center_m", "radius_m", "frame"});
  SceneModelObject object;
  object.name = file.RequireString(node, "name");
  try {
    object.kind = SceneModelObjectKindFromString(file.RequireString(node, "kind"));
  } catch (const InvalidArgumentError& e) {
    file.Fail(node["kind"], "kind", e.what());
  }
  const int own = AddMaterial(model, object.name);
  if (object.kind == SceneModelObject::Kind::kSphere) {
    object.sphere_center = frame.Point(RequireVec3(file, node, "center_m"));
    object.sphere_radius_m = file.RequireDouble(node, "radius_m");
    if (!(object.sphere_radius_m > 0.0)) file.Fail(node, "radius_m", "must be > 0");
    object.material = own;
    return object;
  }
  const std::string mesh_name = file.RequireString(node, "mesh");
  const fs::path mesh_path = fs::path(file.path()).parent_path() / mesh_name;
  const MeshData mesh = LoadMesh(mesh_path.string());
  std::string why;
  if (!mesh.IsValid(&why)) file.Fail(node["mesh"], "mesh", mesh_path.string() + ": " + why);
  const Eigen::Vector3d offset = node["offset"] ? RequireVec3(file, node, "offset") : Eigen::Vector3d::Zero();
  FillMeshObject(mesh, frame, offset, own, model, &object);
  return object;
}

SceneModelLamp ReadLamp(const YamlFile& file, const YAML::Node& node, const FileFrame& frame) {
  file.RejectUnknownKeys(node, {"name", "type", "intensity_w_sr", "position_m", "track", "direction",
                                "cone_half_angle_deg", "falloff_deg", "frame"});
  SceneModelLamp lamp;
  lamp.name = file.RequireString(node, "name");
  const std::string type = node["type"] ? file.RequireString(node, "type") : "point";
  if (type != "point" && type != "spot") file.Fail(node["type"], "type", "expected point or spot");
  lamp.type = type == "spot" ? SceneModelLamp::Type::kSpot : SceneModelLamp::Type::kPoint;
  lamp.intensity_w_sr = RequireVec3(file, node, "intensity_w_sr");
  if (node["position_m"] && node["track"]) file.Fail(node, "track", "give position_m or track, not both");
  if (node["track"]) {
    const YAML::Node track = node["track"];
    if (!track.IsSequence() || track.size() == 0) file.Fail(node, "track", "expected a list of {utc, position_m}");
    for (const YAML::Node& entry : track) {
      file.RejectUnknownKeys(entry, {"utc", "position_m"});
      UtcTime utc;
      try {
        utc = ParseIso8601(file.RequireString(entry, "utc")).utc;
      } catch (const InvalidArgumentError& e) {
        file.Fail(entry["utc"], "utc", e.what());
      }
      lamp.track.push_back({utc, frame.Point(RequireVec3(file, entry, "position_m"))});
    }
  } else {
    lamp.track.push_back({UtcTime{}, frame.Point(RequireVec3(file, node, "position_m"))});
  }
  if (lamp.type == SceneModelLamp::Type::kSpot) {
    lamp.direction = frame.Direction(RequireVec3(file, node, "direction"));
    lamp.cone_half_angle_rad = file.RequireDouble(node, "cone_half_angle_deg") * kDeg;
    lamp.falloff_rad = node["falloff_deg"] ? file.RequireDouble(node, "falloff_deg") * kDeg : 0.0;
  }
  std::string why;
  if (!lamp.IsValid(&why)) file.Fail(node, "name", why);
  return lamp;
}

}  // namespace

SceneModel LoadSceneModelFile(const std::string& path, const Site& session_site) {
  const YamlFile file(path);
  const YAML::Node& root = file.root();
  file.RejectUnknownKeys(root, {"site", "frame", "utm_zone", "cameras", "objects", "known_albedo", "lamps"});
  SceneModel model;
  model.source = "scene model file " + path;
  model.site = session_site;
  if (root["site"]) {
    const YAML::Node site = root["site"];
    file.RejectUnknownKeys(site, {"latitude_deg", "longitude_deg", "height_m"});
    Site given;
    try {
      given = Site::FromDegrees(file.RequireDouble(site, "latitude_deg"), file.RequireDouble(site, "longitude_deg"),
                                site["height_m"] ? file.RequireDouble(site, "height_m") : 0.0);
    } catch (const InvalidArgumentError& e) {
      file.Fail(site, "site", e.what());
    }
    const double apart = EnuFrame(session_site).EnuFromGeodetic(given).norm();
    if (apart > 1.0) {
      file.Fail(site, "site",
                "is " + std::to_string(apart) +
                    " m from the session's site; the session's frames carry the sun for its own site, so the model "
                    "must use it (leave `site:` out)");
    }
  }
  const std::string frame_name = root["frame"] ? file.RequireString(root, "frame") : "enu";
  if (frame_name != "enu" && frame_name != "utm") file.Fail(root["frame"], "frame", "expected enu or utm");
  std::optional<int> zone;
  if (root["utm_zone"]) zone = file.RequireInt(root, "utm_zone", 1, 60);
  const FileFrame enu(model.site, false, zone);
  std::optional<FileFrame> utm;
  try {
    utm.emplace(model.site, true, zone);
  } catch (const InvalidArgumentError& e) {
    if (frame_name == "utm" || zone) file.Fail(root, "utm_zone", e.what());
    // A site outside UTM (polar): an entry asking for UTM is refused by EntryFrame.
  }
  const FileFrame& frame = frame_name == "utm" ? *utm : enu;
  for (const YAML::Node& node : OptionalList(file, root, "cameras")) {
    model.cameras.push_back(ReadCamera(file, node, EntryFrame(file, node, frame, enu, utm)));
  }
  for (const YAML::Node& node : OptionalList(file, root, "objects")) {
    model.objects.push_back(ReadObject(file, node, EntryFrame(file, node, frame, enu, utm), &model));
  }
  for (const YAML::Node& node : OptionalList(file, root, "known_albedo")) {
    file.RejectUnknownKeys(node, {"material", "albedo"});
    const std::string name = file.RequireString(node, "material");
    auto it = std::find_if(model.materials.begin(), model.materials.end(),
                           [&name](const SceneModelMaterial& m) { return m.name == name; });
    if (it == model.materials.end())
      file.Fail(node, "material", "no object or mesh group makes a material '" + name + "'");
    it->albedo = RequireVec3(file, node, "albedo");
  }
  for (const YAML::Node& node : OptionalList(file, root, "lamps")) {
    model.lamps.push_back(ReadLamp(file, node, EntryFrame(file, node, frame, enu, utm)));
  }
  std::string why;
  if (!model.IsValid(&why)) file.Fail(root, "scene model", why);
  return model;
}

bool MeshPlacement::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (frame != "enu" && frame != "utm") return fail("frame '" + frame + "' is not enu or utm");
  if (utm_zone < 0 || utm_zone > 60)
    return fail("UTM zone " + std::to_string(utm_zone) + " is not 1..60 (0: the site's)");
  if (!offset.allFinite()) return fail("the offset must be finite");
  return true;
}

void AddMeshObject(SceneModel* model, const std::string& name, SceneModelObject::Kind kind,
                   const std::string& mesh_path, const MeshPlacement& placement) {
  ThrowIfInvalid(placement, "mesh placement");
  if (name.empty()) throw InvalidArgumentError("the mesh object needs a name");
  if (kind == SceneModelObject::Kind::kSphere) throw InvalidArgumentError("a mesh object is a surface or a solid");
  const MeshData mesh = LoadMesh(mesh_path);
  std::string why;
  if (!mesh.IsValid(&why)) throw InvalidArgumentError(mesh_path + ": " + why);
  const FileFrame frame(model->site, placement.frame == "utm",
                        placement.utm_zone > 0 ? std::optional<int>(placement.utm_zone) : std::nullopt);
  std::erase_if(model->objects, [&](const SceneModelObject& o) { return o.name == name; });
  SceneModelObject object;
  object.name = name;
  object.kind = kind;
  FillMeshObject(mesh, frame, placement.offset, AddMaterial(model, name), model, &object);
  model->objects.push_back(std::move(object));
}

}  // namespace relume
