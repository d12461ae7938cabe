#include "apps/relume/rig_config.h"

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "capture/durable_file.h"
#include "core/error.h"
#include "core/yaml_file.h"
#include "sim/world/scene_yaml.h"

namespace relume::app {

namespace {

// A device's `scene_camera: NAME` becomes the `camera:` mapping of that scene camera.
YAML::Node ExpandSceneCamera(const YamlFile& file, const YAML::Node& device, const sim::World& world) {
  YAML::Node expanded = YAML::Clone(device);
  const YAML::Node name = device["scene_camera"];
  if (!name) return expanded;
  if (device["camera"]) file.Fail(device, "scene_camera", "give either scene_camera or camera, not both");
  PinholeCamera camera;
  try {
    camera = world.Camera(name.as<std::string>());
  } catch (const Error& e) {
    file.Fail(name, "scene_camera", e.what());
  }
  YAML::Node node;
  node["width"] = camera.intrinsics.width;
  node["height"] = camera.intrinsics.height;
  node["fx"] = camera.intrinsics.fx;
  node["fy"] = camera.intrinsics.fy;
  node["cx"] = camera.intrinsics.cx;
  node["cy"] = camera.intrinsics.cy;
  const Eigen::Vector3d p = camera.world_from_camera.translation();
  node["position_m"] = std::vector<double>{p.x(), p.y(), p.z()};
  const Eigen::Quaterniond q(camera.world_from_camera.linear());
  node["rotation_wxyz"] = std::vector<double>{q.w(), q.x(), q.y(), q.z()};
  expanded.remove("scene_camera");
  expanded["camera"] = node;
  return expanded;
}

}  // namespace

RigConfig LoadRigConfig(const std::string& path, const std::optional<std::string>& scene_override) {
  const YamlFile file(path);
  const YAML::Node& root = file.root();
  file.RejectUnknownKeys(root, {"name", "scene", "clock", "schedule", "duration_minutes", "bracket", "retry",
                                "rgbd_burst_frames", "devices"});
  RigConfig rig;
  rig.path = path;
  rig.name = file.RequireString(root, "name");
  {
    std::ifstream stream(path);
    std::stringstream text;
    text << stream.rdbuf();
    rig.yaml_text = text.str();
  }
  if (!root["scene"]) {
    file.Fail(root, "scene",
              "this build records simulated rigs only: name the simulated world (e.g. scene: "
              "../scenes/outdoor-building.yaml)");
  }
  const std::filesystem::path scene_path =
      scene_override ? std::filesystem::path(*scene_override)
                     : std::filesystem::path(path).parent_path() / file.RequireString(root, "scene");
  rig.scene_path = scene_path.string();
  rig.world = std::make_shared<sim::World>(sim::LoadScene(scene_path.string()));
  rig.site = rig.world->scene().site;

  // Simulated clock.
  rig.clock_start = rig.world->scene().time;
  if (const YAML::Node clock = root["clock"]) {
    file.RejectUnknownKeys(clock, {"start", "speedup", "mode"});
    if (clock["mode"] && file.RequireString(clock, "mode") != "event") {
      file.Fail(clock["mode"], "clock.mode", "the only mode is `event`; give `speedup: N` for a running clock");
    }
    if (clock["mode"] && clock["speedup"]) file.Fail(clock, "clock", "give either mode: event or speedup, not both");
    if (clock["start"]) {
      try {
        rig.clock_start = ParseIso8601(file.RequireString(clock, "start")).utc;
      } catch (const InvalidArgumentError& e) {
        file.Fail(clock["start"], "clock.start", e.what());
      }
    }
    if (clock["speedup"]) {
      rig.clock_speedup = file.RequireDouble(clock, "speedup");
      if (!(rig.clock_speedup > 0.0 && rig.clock_speedup <= 1e6)) {
        file.Fail(clock["speedup"], "clock.speedup", "must be within (0, 1e6]");
      }
    }
  }

  // Schedule.
  capture::ScheduleOptions& schedule = rig.recorder.schedule;
  if (const YAML::Node s = root["schedule"]) {
    file.RejectUnknownKeys(s, {"every_minutes", "start", "end", "count", "sun_elevation_step_deg"});
    auto time_of = [&](const char* key) -> std::optional<UtcTime> {
      if (!s[key]) return std::nullopt;
      try {
        return ParseIso8601(file.RequireString(s, key)).utc;
      } catch (const InvalidArgumentError& e) {
        file.Fail(s[key], std::string("schedule.") + key, e.what());
      }
    };
    schedule.start = time_of("start");
    schedule.end = time_of("end");
    if (s["every_minutes"]) {
      schedule.interval = std::chrono::duration_cast<Nanoseconds>(
          std::chrono::duration<double, std::ratio<60>>(file.RequireDouble(s, "every_minutes")));
    }
    if (s["count"]) schedule.count = static_cast<int>(file.RequireDouble(s, "count"));
    if (s["sun_elevation_step_deg"]) {
      schedule.kind = capture::ScheduleOptions::Kind::kSunElevationStep;
      schedule.elevation_step_deg = file.RequireDouble(s, "sun_elevation_step_deg");
    } else if (s["count"] && !s["end"]) {
      schedule.kind = capture::ScheduleOptions::Kind::kCount;
    }
    std::string why;
    if (!schedule.IsValid(&why)) file.Fail(s, "schedule", why);
  }
  if (root["duration_minutes"]) {
    rig.recorder.duration = std::chrono::duration_cast<Nanoseconds>(
        std::chrono::duration<double, std::ratio<60>>(file.RequireDouble(root, "duration_minutes")));
  }
  if (const YAML::Node b = root["bracket"]) {
    file.RejectUnknownKeys(b, {"saturation_fraction", "min_signal_fraction", "overlap_stops", "max_exposures"});
    capture::BracketPlannerOptions& o = rig.recorder.bracket;
    if (b["saturation_fraction"]) o.saturation_fraction = file.RequireDouble(b, "saturation_fraction");
    if (b["min_signal_fraction"]) o.min_signal_fraction = file.RequireDouble(b, "min_signal_fraction");
    if (b["overlap_stops"]) o.overlap_stops = file.RequireDouble(b, "overlap_stops");
    if (b["max_exposures"]) o.max_exposures = static_cast<int>(file.RequireDouble(b, "max_exposures"));
    std::string why;
    if (!o.IsValid(&why)) file.Fail(b, "bracket", why);
  }
  if (const YAML::Node r = root["retry"]) {
    file.RejectUnknownKeys(r, {"max_attempts", "initial_backoff_ms"});
    if (r["max_attempts"]) rig.recorder.retry.max_attempts = static_cast<int>(file.RequireDouble(r, "max_attempts"));
    if (r["initial_backoff_ms"]) {
      rig.recorder.retry.initial_backoff = std::chrono::duration_cast<Nanoseconds>(
          std::chrono::duration<double, std::milli>(file.RequireDouble(r, "initial_backoff_ms")));
    }
    std::string why;
    if (!rig.recorder.retry.IsValid(&why)) file.Fail(r, "retry", why);
  }
  if (root["rgbd_burst_frames"]) {
    rig.rgbd_burst_frames = static_cast<int>(file.RequireDouble(root, "rgbd_burst_frames"));
    if (rig.rgbd_burst_frames < 0) file.Fail(root["rgbd_burst_frames"], "rgbd_burst_frames", "must be >= 0");
  }
  const YAML::Node devices = root["devices"];
  if (!devices || !devices.IsSequence() || devices.size() == 0) {
    file.Fail(root, "devices", "expected a list of devices");
  }
  YAML::Node expanded(YAML::NodeType::Sequence);
  for (const YAML::Node& device : devices) expanded.push_back(ExpandSceneCamera(file, device, *rig.world));
  YAML::Node wrapper;
  wrapper["devices"] = expanded;
  rig.devices = sim::ParseSimDeviceSpecs(file, wrapper);
  std::string why;
  if (!rig.recorder.IsValid(&why)) throw ConfigError(path, 0, "", why);
  return rig;
}

namespace {

std::string ReadText(const std::filesystem::path& path) {
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw IoError(path.string(), "cannot be read");
  std::stringstream text;
  text << stream.rdbuf();
  return text.str();
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  capture::WriteFileDurably(path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

constexpr const char* kRigFolder = "rig";

}  // namespace

void StoreRigWithSession(const RigConfig& rig, const std::filesystem::path& session_dir) {
  namespace fs = std::filesystem;
  const fs::path folder = session_dir / kRigFolder;
  capture::CreateDirectoryDurably(folder);
  WriteText(folder / "rig.yaml", rig.yaml_text);
  if (rig.scene_path.empty()) return;
  // The scene, with every file it names (meshes, chart references) copied into files/ and
  // its paths pointed at the copies, so the session stands alone.
  const YamlFile scene(rig.scene_path);
  const fs::path scene_folder = fs::path(rig.scene_path).parent_path();
  YAML::Node root = YAML::Clone(scene.root());
  int copied = 0;
  auto keep = [&](YAML::Node holder, const char* key, const std::string& fallback) {
    const std::string relative = holder[key] ? holder[key].as<std::string>() : fallback;
    const std::string name = "files/" + std::to_string(copied++) + "-" + fs::path(relative).filename().string();
    if (copied == 1) capture::CreateDirectoryDurably(folder / "files");
    WriteText(folder / name, ReadText(scene_folder / relative));
    holder[key] = name;
  };
  if (YAML::Node objects = root["objects"]; objects && objects.IsSequence()) {
    for (YAML::Node object : objects) {
      if (YAML::Node mesh = object["mesh"]; mesh && mesh.IsMap() && mesh["file"]) keep(mesh, "file", "");
      if (YAML::Node chart = object["colorchecker"]; chart && chart.IsMap()) {
        keep(chart, "reference", "../colorchecker/xrite_classic_2014_lab_d50.yaml");  // the loader's default
      }
    }
  }
  YAML::Emitter emitter;
  emitter << root;
  WriteText(folder / "scene.yaml", "# " + rig.scene_path +
                                       " as recorded by relume capture; files/ holds copies of the files it names\n" +
                                       std::string(emitter.c_str()) + "\n");
}

std::shared_ptr<RigConfig> LoadSessionRig(const std::filesystem::path& session_dir) {
  const std::filesystem::path folder = session_dir / kRigFolder;
  if (!std::filesystem::exists(folder / "rig.yaml")) return nullptr;
  std::optional<std::string> scene;
  if (std::filesystem::exists(folder / "scene.yaml")) scene = (folder / "scene.yaml").string();
  return std::make_shared<RigConfig>(LoadRigConfig((folder / "rig.yaml").string(), scene));
}

}  // namespace relume::app
