#include "sim/world/scene_yaml.h"

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <optional>

#include "core/color.h"
#include "core/error.h"
#include "core/frames.h"
#include "core/mesh_io.h"
#include "core/yaml_file.h"

namespace relume::sim {

namespace {

// Maps positions and directions of the file into the scene's ENU frame.
class FileFrame {
 public:
  FileFrame(const Site& site, std::optional<int> utm_zone) : enu_(site) {
    if (utm_zone) grid_.emplace(site, *utm_zone);
  }
  Eigen::Vector3d Point(const Eigen::Vector3d& p) const {
    return grid_ ? enu_.EnuFromGeodetic(grid_->GeodeticFromGrid(p)) : p;
  }
  Eigen::Vector3d Direction(const Eigen::Vector3d& d) const { return grid_ ? grid_->EnuFromGridDirection(d) : d; }
  double Length(double grid_length) const { return grid_ ? grid_length / grid_->scale() : grid_length; }
  Eigen::Matrix3d Rotation() const {
    Eigen::Matrix3d r;
    for (int k = 0; k < 3; ++k) r.col(k) = Direction(Eigen::Vector3d::Unit(k));
    return r;
  }

 private:
  EnuFrame enu_;
  std::optional<UtmGridFrame> grid_;
};

class SceneReader {
 public:
  explicit SceneReader(const std::string& path) : file_(path), folder_(std::filesystem::path(path).parent_path()) {}
  Scene Read();

 private:
  const YAML::Node& root() const { return file_.root(); }
  [[noreturn]] void Fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
    file_.Fail(at, key, what);
  }
  YAML::Node Map(const YAML::Node& parent, const std::string& key) const {
    const YAML::Node node = parent[key];
    if (!node.IsMap()) Fail(node.IsDefined() ? node : parent, key, "expected a mapping of keys to values");
    return node;
  }
  double Double(const YAML::Node& map, const std::string& key, std::optional<double> fallback = std::nullopt) const {
    if (fallback && !map[key]) return *fallback;
    return file_.RequireDouble(map, key);
  }
  int Int(const YAML::Node& map, const std::string& key, int fallback) const {
    if (!map[key]) return fallback;
    const double value = file_.RequireDouble(map, key);
    if (value != std::floor(value) || std::abs(value) > 1e9) Fail(map[key], key, "expected a whole number");
    return static_cast<int>(value);
  }
  Eigen::Vector3d Vec3(const YAML::Node& map, const std::string& key,
                       std::optional<Eigen::Vector3d> fallback = std::nullopt) const {
    const YAML::Node node = map[key];
    if (!node) {
      if (fallback) return *fallback;
      Fail(map, key, "missing; expected [x, y, z]");
    }
    if (!node.IsSequence() || node.size() != 3) Fail(node, key, "expected three numbers [x, y, z]");
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) {
      const YAML::Node item = node[static_cast<std::size_t>(i)];
      double value = 0.0;
      if (!item.IsScalar() || !YAML::convert<double>::decode(item, value) || !std::isfinite(value)) {
        Fail(item, key, "'" + (item.IsScalar() ? item.Scalar() : std::string("?")) + "' is not a finite number");
      }
      v[i] = value;
    }
    return v;
  }
  Eigen::Vector3d Albedo(const YAML::Node& map, const std::string& key, const Eigen::Vector3d& fallback) const {
    const Eigen::Vector3d a = Vec3(map, key, fallback);
    if (a.minCoeff() < 0.0 || a.maxCoeff() > 1.0) {
      Fail(map[key], key, "albedo must be in [0, 1] per channel (linear sRGB Lambertian reflectance)");
    }
    return a;
  }
  // Light (irradiance, radiance, intensity): non-negative and at most 1e9 per channel, a million
  // times the sun's 1361 W/m^2. Larger finite values reach Inf in the float images.
  Eigen::Vector3d NonNegative(const YAML::Node& map, const std::string& key) const {
    constexpr double kMaxLight = 1e9;
    const Eigen::Vector3d v = Vec3(map, key);
    if (v.minCoeff() < 0.0 || v.maxCoeff() > kMaxLight) {
      Fail(map[key], key, "must be non-negative and at most 1e9 per channel");
    }
    return v;
  }
  Eigen::Vector3d UnitDirection(const YAML::Node& map, const std::string& key,
                                std::optional<Eigen::Vector3d> fallback = std::nullopt) const {
    const Eigen::Vector3d d = Vec3(map, key, fallback);
    if (d.norm() < 1e-12) Fail(map[key], key, "must be a non-zero direction");
    return frame_->Direction(d.normalized());
  }
  std::string Path(const std::string& relative) const {
    const std::filesystem::path p(relative);
    return (p.is_absolute() ? p : folder_ / p).lexically_normal().string();
  }

  void ReadSite(Scene& scene);
  void ReadSun(Scene& scene);
  void ReadSky(Scene& scene);
  void ReadRender(Scene& scene);
  SceneObject ReadObject(const YAML::Node& node, const Scene& scene);
  Motion ReadMotion(const YAML::Node& node, const Scene& scene);
  Lamp ReadLamp(const YAML::Node& node, const Scene& scene);
  SceneCamera ReadCamera(const YAML::Node& node);
  TriangleMesh ConvertMesh(TriangleMesh mesh) const {
    for (Eigen::Vector3d& v : mesh.vertices) v = frame_->Point(v);
    return mesh;
  }

  YamlFile file_;
  std::filesystem::path folder_;
  std::optional<FileFrame> frame_;
};

void SceneReader::ReadSite(Scene& scene) {
  const YAML::Node site = Map(root(), "site");
  file_.RejectUnknownKeys(site, {"latitude_deg", "longitude_deg", "height_m"});
  scene.site = Site{DegToRad(Double(site, "latitude_deg")), DegToRad(Double(site, "longitude_deg")),
                    Double(site, "height_m", 0.0)};
  std::string why;
  if (!scene.site.IsValid(&why)) Fail(site, "site", why);
  try {
    scene.time = ParseIso8601(file_.RequireString(root(), "time")).utc;
  } catch (const InvalidArgumentError& e) {
    Fail(root()["time"], "time", e.what());
  }
  if (root()["utm_zone"]) {
    const int zone = Int(root(), "utm_zone", 0);
    if (zone < 1 || zone > 60) Fail(root()["utm_zone"], "utm_zone", "expected a UTM zone number in 1..60");
    scene.utm_zone = zone;
  }
  try {
    frame_.emplace(scene.site, scene.utm_zone);
  } catch (const InvalidArgumentError& e) {
    Fail(root()["utm_zone"], "utm_zone", e.what());
  }
}

void SceneReader::ReadSun(Scene& scene) {
  if (!root()["sun"]) {
    scene.sun.enabled = false;
    return;
  }
  const YAML::Node sun = Map(root(), "sun");
  file_.RejectUnknownKeys(
      sun, {"enabled", "irradiance_w_m2", "angular_diameter_deg", "direction", "pressure_hpa", "temperature_c"});
  if (sun["enabled"] && !YAML::convert<bool>::decode(sun["enabled"], scene.sun.enabled)) {
    Fail(sun["enabled"], "enabled", "expected true or false");
  }
  if (sun["irradiance_w_m2"]) scene.sun.irradiance_w_m2 = NonNegative(sun, "irradiance_w_m2");
  scene.sun.angular_diameter_rad = DegToRad(Double(sun, "angular_diameter_deg", 0.53));
  if (scene.sun.angular_diameter_rad < 0.0 || scene.sun.angular_diameter_rad >= DegToRad(10.0)) {
    Fail(sun["angular_diameter_deg"], "angular_diameter_deg", "expected a value in [0, 10) degrees");
  }
  if (sun["direction"]) scene.sun.direction_in_enu = UnitDirection(sun, "direction");
  scene.sun.sun_options.pressure_hpa = Double(sun, "pressure_hpa", scene.sun.sun_options.pressure_hpa);
  scene.sun.sun_options.temperature_c = Double(sun, "temperature_c", scene.sun.sun_options.temperature_c);
  std::string why;
  if (!scene.sun.sun_options.IsValid(&why)) Fail(sun, "sun", why);
}

void SceneReader::ReadSky(Scene& scene) {
  if (!root()["sky"]) return;
  const YAML::Node sky = Map(root(), "sky");
  file_.RejectUnknownKeys(sky, {"type", "radiance", "zenith_radiance", "horizon_radiance"});
  const std::string type = file_.RequireString(sky, "type");
  if (type == "black") {
    scene.sky = Sky::Black();
  } else if (type == "uniform") {
    scene.sky = Sky::Uniform(NonNegative(sky, "radiance"));
  } else if (type == "gradient") {
    scene.sky = Sky::Gradient(NonNegative(sky, "zenith_radiance"), NonNegative(sky, "horizon_radiance"));
  } else {
    Fail(sky["type"], "type", "unknown sky type '" + type + "'; expected black, uniform or gradient");
  }
}

void SceneReader::ReadRender(Scene& scene) {
  if (!root()["render"]) return;
  const YAML::Node render = Map(root(), "render");
  file_.RejectUnknownKeys(render,
                          {"sun_samples", "sky_samples", "indirect_bounces", "indirect_samples", "seed", "threads"});
  RenderOptions& o = scene.render;
  o.sun_samples = Int(render, "sun_samples", o.sun_samples);
  o.sky_samples = Int(render, "sky_samples", o.sky_samples);
  o.indirect_bounces = Int(render, "indirect_bounces", o.indirect_bounces);
  o.indirect_samples = Int(render, "indirect_samples", o.indirect_samples);
  o.seed = static_cast<std::uint64_t>(Int(render, "seed", static_cast<int>(o.seed)));
  o.threads = Int(render, "threads", o.threads);
  std::string why;
  if (!o.IsValid(&why)) Fail(render, "render", why);
}

Motion SceneReader::ReadMotion(const YAML::Node& node, const Scene& scene) {
  Motion motion;
  motion.reference_time = scene.time;
  file_.RejectUnknownKeys(node, {"type", "velocity_mps", "center", "axis", "period_s", "waypoints"});
  const std::string type = file_.RequireString(node, "type");
  if (type == "linear") {
    motion.type = Motion::Type::kLinear;
    motion.velocity_mps = frame_->Length(1.0) * frame_->Direction(Vec3(node, "velocity_mps"));
  } else if (type == "circular") {
    motion.type = Motion::Type::kCircular;
    motion.center = frame_->Point(Vec3(node, "center"));
    motion.axis = UnitDirection(node, "axis", Eigen::Vector3d::UnitZ());
    motion.period_s = Double(node, "period_s");
    if (motion.period_s == 0.0) Fail(node["period_s"], "period_s", "must be non-zero (negative turns clockwise)");
  } else if (type == "path") {
    motion.type = Motion::Type::kPath;
    const YAML::Node waypoints = node["waypoints"];
    if (!waypoints.IsSequence() || waypoints.size() == 0) Fail(node, "waypoints", "expected a list of {t_s, position}");
    for (const YAML::Node& w : waypoints) {
      file_.RejectUnknownKeys(w, {"t_s", "position"});
      motion.waypoints.push_back({Double(w, "t_s"), frame_->Point(Vec3(w, "position"))});
      const std::size_t n = motion.waypoints.size();
      if (n > 1 && !(motion.waypoints[n - 1].t_s > motion.waypoints[n - 2].t_s)) {
        Fail(w["t_s"], "t_s", "waypoint times must increase");
      }
    }
  } else if (type != "static") {
    Fail(node["type"], "type", "unknown motion '" + type + "'; expected static, linear, circular or path");
  }
  return motion;
}

SceneObject SceneReader::ReadObject(const YAML::Node& node, const Scene& scene) {
  if (!node.IsMap()) Fail(node, "objects", "each object must be a mapping");
  file_.RejectUnknownKeys(node, {"name", "albedo", "plane", "box", "sphere", "mesh", "colorchecker", "motion"});
  SceneObject object;
  object.name = file_.RequireString(node, "name");
  object.albedo = Albedo(node, "albedo", Eigen::Vector3d::Constant(0.5));
  int shapes = 0;
  for (const char* key : {"plane", "box", "sphere", "mesh", "colorchecker"}) shapes += node[key] ? 1 : 0;
  if (shapes != 1) Fail(node, object.name, "an object needs exactly one of: plane, box, sphere, mesh, colorchecker");

  if (node["plane"]) {
    const YAML::Node plane = Map(node, "plane");
    object.shape = SceneObject::Shape::kPlane;
    file_.RejectUnknownKeys(plane, {"center", "size", "origin", "edge_u", "edge_v"});
    TriangleMesh mesh;
    if (plane["origin"]) {
      mesh = MakeQuad(Vec3(plane, "origin"), Vec3(plane, "edge_u"), Vec3(plane, "edge_v"));
      if ((mesh.vertices[1] - mesh.vertices[0]).cross(mesh.vertices[3] - mesh.vertices[0]).norm() <= 0.0) {
        Fail(plane, "edge_u", "edge_u and edge_v must span a parallelogram (not parallel, not zero)");
      }
    } else {
      const Eigen::Vector3d center = Vec3(plane, "center");
      const YAML::Node size = plane["size"];
      if (!size.IsSequence() || size.size() != 2) Fail(plane, "size", "expected [east_m, north_m]");
      double sx = 0.0, sy = 0.0;
      if (!YAML::convert<double>::decode(size[0], sx) || !YAML::convert<double>::decode(size[1], sy) ||
          !(sx > 0.0 && sy > 0.0 && std::isfinite(sx) && std::isfinite(sy))) {
        Fail(size, "size", "must be two positive numbers");
      }
      mesh = MakeQuad(center - Eigen::Vector3d(0.5 * sx, 0.5 * sy, 0.0), Eigen::Vector3d(sx, 0, 0),
                      Eigen::Vector3d(0, sy, 0));
    }
    object.mesh = ConvertMesh(std::move(mesh));
  } else if (node["box"]) {
    const YAML::Node box = Map(node, "box");
    object.shape = SceneObject::Shape::kBox;
    file_.RejectUnknownKeys(box, {"center", "size", "yaw_deg"});
    const Eigen::Vector3d size = Vec3(box, "size");
    if (size.minCoeff() <= 0.0) Fail(box["size"], "size", "box sizes must be positive");
    object.mesh = ConvertMesh(MakeBox(Vec3(box, "center"), size, DegToRad(Double(box, "yaw_deg", 0.0))));
  } else if (node["sphere"]) {
    const YAML::Node sphere = Map(node, "sphere");
    object.shape = SceneObject::Shape::kSphere;
    file_.RejectUnknownKeys(sphere, {"center", "radius_m"});
    object.sphere_center = frame_->Point(Vec3(sphere, "center"));
    object.sphere_radius_m = frame_->Length(Double(sphere, "radius_m"));
    if (!(object.sphere_radius_m > 0.0)) Fail(sphere["radius_m"], "radius_m", "must be positive");
  } else if (node["mesh"]) {
    const YAML::Node m = Map(node, "mesh");
    object.shape = SceneObject::Shape::kMesh;
    file_.RejectUnknownKeys(m, {"file", "offset", "material_albedo"});
    const std::string path = Path(file_.RequireString(m, "file"));
    TriangleMesh mesh;
    try {
      mesh = LoadMesh(path);
    } catch (const ConfigError&) {
      throw;
    } catch (const Error& e) {
      Fail(m["file"], "file", e.what());
    }
    const Eigen::Vector3d offset = Vec3(m, "offset", Eigen::Vector3d::Zero());
    for (Eigen::Vector3d& v : mesh.vertices) v += offset;
    if (m["material_albedo"]) {
      const YAML::Node materials = Map(m, "material_albedo");
      std::map<std::string, Eigen::Vector3d> albedo;
      for (const auto& entry : materials) albedo[entry.first.Scalar()] = Albedo(materials, entry.first.Scalar(), {});
      mesh.face_albedo.assign(mesh.triangles.size(), Eigen::Vector3d::Constant(NAN));
      for (std::size_t i = 0; i < mesh.face_material.size(); ++i) {
        const auto found = albedo.find(mesh.face_material[i]);
        if (found != albedo.end()) mesh.face_albedo[i] = found->second;
      }
    }
    object.mesh = ConvertMesh(std::move(mesh));
  } else {
    const YAML::Node c = Map(node, "colorchecker");
    file_.RejectUnknownKeys(
        c, {"center", "normal", "up", "reference", "patch_size_m", "gap_m", "border_m", "frame_albedo"});
    ColorCheckerGeometry g;
    g.center = Vec3(c, "center");
    g.normal = Vec3(c, "normal");
    g.up = Vec3(c, "up", Eigen::Vector3d::UnitZ());
    if (g.normal.norm() < 1e-9 || g.normal.normalized().cross(g.up.normalized()).norm() < 1e-3) {
      Fail(c, "normal", "normal must be non-zero and not parallel to up");
    }
    g.patch_size_m = Double(c, "patch_size_m", g.patch_size_m);
    g.gap_m = Double(c, "gap_m", g.gap_m);
    g.border_m = Double(c, "border_m", g.border_m);
    if (!(g.patch_size_m > 0.0 && g.gap_m >= 0.0 && g.border_m >= 0.0)) {
      Fail(c, "patch_size_m", "patch size must be positive, gap and border non-negative");
    }
    g.frame_albedo = Albedo(c, "frame_albedo", g.frame_albedo);
    const std::string reference_path =
        Path(c["reference"] ? file_.RequireString(c, "reference") : "../colorchecker/xrite_classic_2014_lab_d50.yaml");
    const ColorCheckerReference reference = LoadColorCheckerReference(reference_path);
    std::vector<std::string> names;
    std::vector<Eigen::Vector3d> rgb;
    for (const ColorCheckerPatch& patch : reference.patches) {
      names.push_back(patch.name);
      rgb.push_back(patch.linear_rgb);
    }
    object = MakeColorChecker(object.name, g, names, rgb);
    object.mesh = ConvertMesh(std::move(object.mesh));
    ColorCheckerLayout& layout = *object.colorchecker;
    for (Eigen::Vector3d& p : layout.centers_in_world) p = frame_->Point(p);
    for (Eigen::Vector3d& p : layout.corners_in_world) p = frame_->Point(p);
    layout.normal_in_world = frame_->Direction(layout.normal_in_world);
  }
  if (node["motion"]) object.motion = ReadMotion(Map(node, "motion"), scene);
  std::string why;
  if (!object.IsValid(&why)) Fail(node, object.name, why);
  return object;
}

Lamp SceneReader::ReadLamp(const YAML::Node& node, const Scene& scene) {
  if (!node.IsMap()) Fail(node, "lamps", "each lamp must be a mapping");
  file_.RejectUnknownKeys(node, {"name", "type", "position", "intensity_w_sr", "direction", "cone_deg", "falloff_deg",
                                 "positions", "motion"});
  Lamp lamp;
  lamp.name = file_.RequireString(node, "name");
  const std::string type = node["type"] ? file_.RequireString(node, "type") : "point";
  if (type == "spot") {
    lamp.type = Lamp::Type::kSpot;
    lamp.direction = UnitDirection(node, "direction");
    lamp.cone_half_angle_rad = DegToRad(Double(node, "cone_deg", 30.0));
    lamp.falloff_rad = DegToRad(Double(node, "falloff_deg", 5.0));
  } else if (type != "point") {
    Fail(node["type"], "type", "unknown lamp type '" + type + "'; expected point or spot");
  }
  lamp.intensity_w_sr = NonNegative(node, "intensity_w_sr");
  if (node["positions"]) {
    const YAML::Node positions = Map(node, "positions");
    for (const auto& entry : positions) {
      lamp.named_positions[entry.first.Scalar()] = frame_->Point(Vec3(positions, entry.first.Scalar()));
    }
  }
  if (node["position"] && node["position"].IsScalar()) {
    const std::string name = node["position"].Scalar();
    const auto found = lamp.named_positions.find(name);
    if (found == lamp.named_positions.end()) Fail(node["position"], "position", "no entry '" + name + "' in positions");
    lamp.position = found->second;
  } else {
    lamp.position = frame_->Point(Vec3(node, "position"));
  }
  if (node["motion"]) lamp.motion = ReadMotion(Map(node, "motion"), scene);
  std::string why;
  if (!lamp.IsValid(&why)) Fail(node, lamp.name, why);
  return lamp;
}

SceneCamera SceneReader::ReadCamera(const YAML::Node& node) {
  if (!node.IsMap()) Fail(node, "cameras", "each camera must be a mapping");
  file_.RejectUnknownKeys(
      node, {"name", "width", "height", "hfov_deg", "eye", "target", "up", "position", "quaternion_wxyz"});
  SceneCamera camera;
  camera.name = file_.RequireString(node, "name");
  const int width = Int(node, "width", 640);
  const int height = Int(node, "height", 480);
  const double hfov_deg = Double(node, "hfov_deg");
  if (width <= 0 || height <= 0) Fail(node, "width", "image size must be positive");
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) Fail(node["hfov_deg"], "hfov_deg", "expected a value in (0, 180)");
  camera.horizontal_fov_rad = DegToRad(hfov_deg);
  const PinholeIntrinsics intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, camera.horizontal_fov_rad);
  std::string why;
  if (!intrinsics.IsValid(&why)) Fail(node, "width", why);
  if (node["eye"]) {
    const Eigen::Vector3d eye = frame_->Point(Vec3(node, "eye"));
    const Eigen::Vector3d target = frame_->Point(Vec3(node, "target"));
    const Eigen::Vector3d up = UnitDirection(node, "up", Eigen::Vector3d::UnitZ());
    if ((target - eye).norm() < 1e-9) Fail(node["target"], "target", "target must differ from eye");
    if ((target - eye).normalized().cross(up).norm() < 1e-6) Fail(node["up"], "up", "view direction is parallel to up");
    camera.camera = PinholeCamera::LookAt(intrinsics, eye, target, up);
  } else if (node["position"]) {
    const YAML::Node q = node["quaternion_wxyz"];
    if (!q.IsSequence() || q.size() != 4) {
      Fail(q.IsDefined() ? q : node, "quaternion_wxyz", "expected [w, x, y, z] (world_from_camera rotation)");
    }
    Eigen::Quaterniond rotation(q[0].as<double>(), q[1].as<double>(), q[2].as<double>(), q[3].as<double>());
    if (!(rotation.norm() > 1e-9)) Fail(q, "quaternion_wxyz", "must be a non-zero quaternion");
    rotation.normalize();
    camera.camera.intrinsics = intrinsics;
    camera.camera.world_from_camera.linear() = frame_->Rotation() * rotation.toRotationMatrix();
    camera.camera.world_from_camera.translation() = frame_->Point(Vec3(node, "position"));
  } else {
    Fail(node, camera.name, "a camera needs eye + target (+ up) or position + quaternion_wxyz");
  }
  return camera;
}

Scene SceneReader::Read() {
  file_.RejectUnknownKeys(root(), {"name", "description", "site", "time", "utm_zone", "sun", "sky", "render", "objects",
                                   "lamps", "cameras"});
  Scene scene;
  scene.source_path = file_.path();
  scene.name =
      root()["name"] ? file_.RequireString(root(), "name") : std::filesystem::path(file_.path()).stem().string();
  ReadSite(scene);
  ReadSun(scene);
  ReadSky(scene);
  ReadRender(scene);
  const YAML::Node objects = root()["objects"];
  if (!objects.IsSequence() || objects.size() == 0)
    Fail(objects.IsDefined() ? objects : root(), "objects", "expected a list of objects");
  for (const YAML::Node& node : objects) {
    SceneObject object = ReadObject(node, scene);
    if (scene.ObjectIndex(object.name) >= 0)
      Fail(node["name"], "name", "another object is named '" + object.name + "'");
    scene.objects.push_back(std::move(object));
  }
  if (root()["lamps"]) {
    const YAML::Node lamps = root()["lamps"];
    if (!lamps.IsSequence()) Fail(lamps, "lamps", "expected a list of lamps");
    for (const YAML::Node& node : lamps) scene.lamps.push_back(ReadLamp(node, scene));
  }
  if (root()["cameras"]) {
    const YAML::Node cameras = root()["cameras"];
    if (!cameras.IsSequence()) Fail(cameras, "cameras", "expected a list of cameras");
    for (const YAML::Node& node : cameras) {
      SceneCamera camera = ReadCamera(node);
      for (const SceneCamera& other : scene.cameras) {
        if (other.name == camera.name) Fail(node["name"], "name", "another camera is named '" + camera.name + "'");
      }
      scene.cameras.push_back(std::move(camera));
    }
  }
  std::string why;
  if (!scene.IsValid(&why)) Fail(root(), "scene", why);
  return scene;
}

}  // namespace

Scene LoadScene(const std::string& path) {
  try {
    return SceneReader(path).Read();
  } catch (const YAML::Exception& e) {
    // A value of the wrong type deep inside (e.g. "enabled: maybe").
    throw ConfigError(path, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", "unexpected value: " + e.msg);
  }
}

}  // namespace relume::sim
