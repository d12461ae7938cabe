#include "rig/rig_config.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "capture/durable_file.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/input_file.h"
#include "core/yaml_file.h"
#include "sim/world/scene_yaml.h"

namespace relume::rig {

namespace {

// A duration given in units of `seconds_per_unit` (minutes: 60), checked before it is narrowed
// to int64 nanoseconds: at most 100 years, well inside their 292. Zero and negative values are
// left to the options' IsValid, which knows whether they mean anything.
Nanoseconds RequireDuration(const YamlFile& file, const YAML::Node& map, const char* key, double seconds_per_unit) {
  constexpr double kMaxSeconds = 100.0 * 365.25 * 86400.0;
  const double seconds = file.RequireDouble(map, key) * seconds_per_unit;
  if (std::abs(seconds) > kMaxSeconds) file.Fail(map[key], key, "must be at most 100 years");
  return std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(seconds));
}

// A simulated clock without `clock: {start}` starts where the schedule does (not at the scene's
// time, which may lie after the schedule's end: a capture of 0 frames that exits 0). A clock
// that starts after the schedule's end is an error.
void MatchClockToSchedule(const YamlFile& file, const YAML::Node& root, RigConfig& rig) {
  const capture::ScheduleOptions& schedule = rig.recorder.schedule;
  const bool clock_start_given = root["clock"] && root["clock"]["start"];
  if (!clock_start_given && schedule.start) rig.clock_start = *schedule.start;
  if (schedule.end && *schedule.end < rig.clock_start) {
    file.Fail(root["schedule"]["end"], "schedule.end",
              "the schedule ends (" + FormatIso8601(*schedule.end, std::chrono::seconds{0}, 0) +
                  ") before the simulated clock starts (" + FormatIso8601(rig.clock_start, std::chrono::seconds{0}, 0) +
                  (clock_start_given ? ", clock.start" : ", the scene's time") + "): nothing would be recorded. " +
                  (clock_start_given ? "Set clock.start before the schedule's end"
                                     : "Give the schedule a start, or set clock.start"));
  }
}

// stream.KEY: "640x480" -> {640, 480}.
std::pair<int, int> ParseSize(const YamlFile& file, const YAML::Node& stream, const char* key) {
  const std::string text = file.RequireString(stream, key);
  int width = 0, height = 0;
  char x = 0, rest = 0;
  std::istringstream in(text);
  if (!(in >> width >> x >> height) || x != 'x' || in >> rest || width <= 0 || height <= 0) {
    file.Fail(stream[key], std::string("stream.") + key, "expected WIDTHxHEIGHT, e.g. 640x480");
  }
  return {width, height};
}

RgbdStreamRequest ParseStreamRequest(const YamlFile& file, const YAML::Node& stream) {
  if (!stream.IsMap()) file.Fail(stream, "stream", "expected a map, e.g. {depth: 640x480, fps: 30}");
  file.RejectUnknownKeys(stream, {"depth", "color", "fps", "registered", "synced"});
  RgbdStreamRequest request;
  if (stream["depth"]) request.depth_size = ParseSize(file, stream, "depth");
  if (stream["color"]) request.color_size = ParseSize(file, stream, "color");
  if (stream["fps"]) {
    request.fps = file.RequireDouble(stream, "fps");
    if (!(*request.fps > 0.0)) file.Fail(stream["fps"], "stream.fps", "must be positive");
  }
  auto flag = [&](const char* key) -> std::optional<bool> {
    if (!stream[key]) return std::nullopt;
    try {
      return stream[key].as<bool>();
    } catch (const YAML::Exception&) {
      file.Fail(stream[key], std::string("stream.") + key, "expected true or false");
    }
  };
  request.registered = flag("registered");
  request.synced = flag("synced");
  return request;
}

RegistryDeviceSpec ParseRegistryDevice(const YamlFile& file, const YAML::Node& device) {
  file.RejectUnknownKeys(
      device, {"backend", "id", "model", "serial", "port", "uri", "session", "device", "settings", "stream"});
  RegistryDeviceSpec spec;
  spec.backend = file.RequireString(device, "backend");
  spec.line = device.Mark().line + 1;
  const std::vector<std::string> backends = {"gphoto2", "aravis", "openni2", "playback"};
  if (std::find(backends.begin(), backends.end(), spec.backend) == backends.end()) {
    file.Fail(device["backend"], "backend", "expected sim, gphoto2, aravis, openni2 or playback");
  }
  auto optional = [&](const char* key) { return device[key] ? file.RequireString(device, key) : std::string(); };
  spec.id = optional("id");
  spec.model = optional("model");
  spec.serial = optional("serial");
  spec.port = optional("port");
  spec.uri = optional("uri");
  if (const YAML::Node settings = device["settings"]) {
    if (spec.backend != "gphoto2") {
      file.Fail(settings, "settings", "camera settings are for `backend: gphoto2` cameras only");
    }
    if (!settings.IsMap() || settings.size() == 0) {
      file.Fail(settings, "settings", "expected a map of camera settings, e.g. {imageformat: RAW}");
    }
    for (const auto& entry : settings) {
      if (!entry.first.IsScalar() || !entry.second.IsScalar()) {
        file.Fail(entry.second, "settings", "expected a name and a value for each setting");
      }
      spec.camera_settings.emplace_back(entry.first.Scalar(), entry.second.Scalar());
    }
  }
  if (const YAML::Node stream = device["stream"]) {
    if (spec.backend != "openni2" && spec.backend != "playback") {
      file.Fail(stream, "stream", "a stream is chosen for RGB-D sensors (`backend: openni2` or `playback`) only");
    }
    spec.stream = ParseStreamRequest(file, stream);
  }
  if (spec.backend == "playback") {
    spec.session = (std::filesystem::path(file.path()).parent_path() / file.RequireString(device, "session")).string();
    spec.device = file.RequireString(device, "device");
  } else if (device["session"] || device["device"]) {
    file.Fail(device, "session", "session and device are for `backend: playback` only");
  } else if (spec.id.empty() && spec.model.empty() && spec.serial.empty() && spec.port.empty() && spec.uri.empty()) {
    file.Fail(device, "backend", "say which device: give at least one of id, model, serial, port, uri");
  }
  return spec;
}

}  // namespace

bool RgbdStreamRequest::Matches(const drivers::RgbdStreamConfig& c) const {
  return (!depth_size || *depth_size == std::pair(c.depth_width, c.depth_height)) &&
         (!color_size || *color_size == std::pair(c.color_width, c.color_height)) &&
         (!fps || std::abs(*fps - c.fps) < 1e-6 * std::max(1.0, c.fps)) &&
         (!registered || *registered == c.register_depth_to_color) && (!synced || *synced == c.sync_depth_and_color);
}

std::string RgbdStreamRequest::Describe() const {
  std::ostringstream s;
  auto sep = [&]() -> std::ostringstream& {
    if (s.tellp() > 0) s << ", ";
    return s;
  };
  if (depth_size) sep() << "depth " << depth_size->first << "x" << depth_size->second;
  if (color_size) sep() << "colour " << color_size->first << "x" << color_size->second;
  if (fps) sep() << *fps << " fps";
  if (registered) sep() << (*registered ? "registered" : "unregistered");
  if (synced) sep() << (*synced ? "synced" : "unsynced");
  return s.tellp() > 0 ? s.str() : "any stream";
}

std::string RegistryDeviceSpec::Describe() const {
  std::string keys;
  auto add = [&](const char* key, const std::string& value) {
    if (!value.empty()) keys += std::string(keys.empty() ? "" : ", ") + key + " \"" + value + "\"";
  };
  add("id", id);
  add("model", model);
  add("serial", serial);
  add("port", port);
  add("uri", uri);
  add("session", session);
  add("device", device);
  return backend + " device (" + keys + ")" + (line > 0 ? " at line " + std::to_string(line) : "");
}

namespace {

// The devices: simulated ones (no `backend:` or `backend: sim`) and registry ones, which a rig
// may not mix (playback aside), and the one session playback devices come from.
struct RigDevices {
  std::vector<YAML::Node> sim_devices;
  bool real_devices = false;
  std::optional<std::string> playback_session;
};

RigDevices ParseRigDevices(const YamlFile& file, const YAML::Node& root, RigConfig& rig) {
  RigDevices out;
  std::vector<YAML::Node>& sim_devices = out.sim_devices;
  const YAML::Node devices = root["devices"];
  if (!devices || !devices.IsSequence() || devices.size() == 0) {
    file.Fail(root, "devices", "expected a list of devices");
  }
  for (const YAML::Node& device : devices) {
    if (!device.IsMap()) {
      file.Fail(device, "devices",
                "each device is a mapping (a simulated device with id, kind and camera, or "
                "backend: gphoto2 | aravis | openni2 | playback with keys that find it)");
    }
    if (device["backend"] && file.RequireString(device, "backend") != "sim") {
      rig.registry_devices.push_back(ParseRegistryDevice(file, device));
    } else {
      sim_devices.push_back(device);
    }
  }
  out.real_devices = std::any_of(rig.registry_devices.begin(), rig.registry_devices.end(),
                                 [](const RegistryDeviceSpec& d) { return d.backend != "playback"; });
  if (out.real_devices && sim_devices.size() > 0) {
    file.Fail(devices, "devices",
              "a rig cannot mix simulated and real devices (simulated ones run on a simulated clock, real ones on "
              "the host's); split it into two rigs");
  }
  for (const RegistryDeviceSpec& d : rig.registry_devices) {
    if (d.backend != "playback") continue;
    if (out.playback_session && *out.playback_session != d.session) {
      file.Fail(devices, "devices", "all playback devices of a rig must come from one session");
    }
    out.playback_session = d.session;
  }
  return out;
}

// The simulated world (scene:) and the site (site:, the world's, or the played session's).
void ParseWorldAndSite(const YamlFile& file, const YAML::Node& root, const std::string& path,
                       const std::optional<std::string>& scene_override, const RigDevices& devices, RigConfig& rig) {
  if (devices.sim_devices.size() > 0 && !root["scene"]) {
    file.Fail(root, "scene",
              "simulated devices need the simulated world: name it (e.g. scene: ../scenes/outdoor-building.yaml)");
  }
  if (root["scene"] || scene_override) {
    const std::filesystem::path scene_path =
        scene_override ? std::filesystem::path(*scene_override)
                       : std::filesystem::path(path).parent_path() / file.RequireString(root, "scene");
    rig.scene_path = scene_path.string();
    rig.world = std::make_shared<sim::World>(sim::LoadScene(scene_path.string()));
    rig.site = rig.world->scene().site;
    rig.clock_start = rig.world->scene().time;
  }
  if (const YAML::Node site = root["site"]) {
    const std::filesystem::path site_path =
        std::filesystem::path(path).parent_path() / file.RequireString(root, "site");
    rig.site = LoadSiteConfig(site_path.string()).site;
  } else if (!rig.world && devices.playback_session) {
    const capture::SessionReader session(*devices.playback_session);
    rig.site = session.info().site;
    rig.clock_start = session.info().created_utc;
  } else if (!rig.world) {
    file.Fail(root, "site", "a rig without a simulated world needs its site: site: ../sites/NAME.yaml");
  }
}

// clock: (simulated rigs only).
void ParseClock(const YamlFile& file, const YAML::Node& root, RigConfig& rig) {
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
}

// schedule: and duration_minutes:.
void ParseSchedule(const YamlFile& file, const YAML::Node& root, RigConfig& rig) {
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
    if (s["every_minutes"]) schedule.interval = RequireDuration(file, s, "every_minutes", 60.0);
    if (s["count"]) schedule.count = file.RequireInt(s, "count", 0, std::numeric_limits<int>::max());
    if (s["sun_elevation_step_deg"]) {
      schedule.kind = capture::ScheduleOptions::Kind::kSunElevationStep;
      schedule.elevation_step_deg = file.RequireDouble(s, "sun_elevation_step_deg");
    } else if (s["count"] && !s["end"]) {
      schedule.kind = capture::ScheduleOptions::Kind::kCount;
    }
    std::string why;
    if (!schedule.IsValid(&why)) file.Fail(s, "schedule", why);
    if (!rig.host_clock) MatchClockToSchedule(file, root, rig);
  }
  if (root["duration_minutes"]) {
    rig.recorder.duration = RequireDuration(file, root, "duration_minutes", 60.0);
  }
}

// bracket: and retry: (the recorder's planner and retry options).
void ParseRecorderOptions(const YamlFile& file, const YAML::Node& root, RigConfig& rig) {
  if (const YAML::Node b = root["bracket"]) {
    file.RejectUnknownKeys(
        b, {"saturation_fraction", "min_signal_fraction", "overlap_stops", "max_exposures", "unequal_steps"});
    capture::BracketPlannerOptions& o = rig.recorder.bracket;
    if (b["saturation_fraction"]) o.saturation_fraction = file.RequireDouble(b, "saturation_fraction");
    if (b["min_signal_fraction"]) o.min_signal_fraction = file.RequireDouble(b, "min_signal_fraction");
    if (b["overlap_stops"]) o.overlap_stops = file.RequireDouble(b, "overlap_stops");
    if (b["max_exposures"]) o.max_exposures = file.RequireInt(b, "max_exposures", 1, 64);
    if (b["unequal_steps"]) o.unequal_steps = file.RequireDouble(b, "unequal_steps");
    std::string why;
    if (!o.IsValid(&why)) file.Fail(b, "bracket", why);
  }
  if (const YAML::Node r = root["retry"]) {
    file.RejectUnknownKeys(r, {"max_attempts", "initial_backoff_ms"});
    if (r["max_attempts"]) rig.recorder.retry.max_attempts = file.RequireInt(r, "max_attempts", 1, 1000);
    if (r["initial_backoff_ms"]) {
      rig.recorder.retry.initial_backoff = RequireDuration(file, r, "initial_backoff_ms", 1e-3);
    }
    std::string why;
    if (!rig.recorder.retry.IsValid(&why)) file.Fail(r, "retry", why);
  }
}

// rgbd_burst_frames:, rgbd_format:, rgbd_depth: and storage_faults:.
void ParseStorage(const YamlFile& file, const YAML::Node& root, RigConfig& rig) {
  if (root["rgbd_burst_frames"]) {
    rig.rgbd_burst_frames = file.RequireInt(root, "rgbd_burst_frames", 0, 1'000'000);
  }
  if (root["rgbd_format"]) {
    try {
      rig.storage.rgbd_format = capture::ParseRgbdFileFormat(file.RequireString(root, "rgbd_format"));
    } catch (const InvalidArgumentError& e) {
      file.Fail(root["rgbd_format"], "rgbd_format", e.what());
    }
  }
  if (root["rgbd_depth"]) {
    try {
      rig.storage.depth_units = capture::ParseDepthUnits(file.RequireString(root, "rgbd_depth"));
    } catch (const InvalidArgumentError& e) {
      file.Fail(root["rgbd_depth"], "rgbd_depth", e.what());
    }
  }
  if (const YAML::Node f = root["storage_faults"]) {
    // Slow and full disks for soaks of simulated rigs (capture/session.h StorageFaultPlan).
    if (rig.host_clock) file.Fail(f, "storage_faults", "only simulated rigs take injected storage faults");
    file.RejectUnknownKeys(f, {"slow_write_ms", "full_after_mb"});
    capture::StorageFaultPlan& plan = rig.storage.storage_faults;
    if (f["slow_write_ms"]) plan.slow_write_ms = file.RequireDouble(f, "slow_write_ms");
    if (f["full_after_mb"]) plan.full_after_mb = file.RequireDouble(f, "full_after_mb");
    std::string why;
    if (!plan.IsValid(&why)) file.Fail(f, "storage_faults", why);
  }
}

// The simulated devices, parsed from the file's own nodes so that every error names the
// device's own line.
void ParseSimDevices(const YamlFile& file, const std::vector<YAML::Node>& sim_devices, RigConfig& rig) {
  const sim::SceneCameraLookup scene_camera = [&rig](const std::string& name) { return rig.world->Camera(name); };
  std::set<std::string> sim_ids;
  for (const YAML::Node& device : sim_devices) {
    rig.devices.push_back(sim::ParseSimDevice(file, device, scene_camera));
    if (!sim_ids.insert(rig.devices.back().id).second) file.Fail(device["id"], "id", "device id used twice");
  }
}

// A rig that plays a session back stores RGB-D frames as that session stored them, unless it
// says otherwise: replaying float-metre depth into 16-bit millimetres would quantise it (and the
// sh pipeline would then see stairs the recording does not have).
void StoreAsRecorded(const YAML::Node& root, const RigDevices& devices, RigConfig& rig) {
  if (!devices.playback_session || (root["rgbd_depth"] && root["rgbd_format"])) return;
  const capture::SessionReader session(*devices.playback_session);
  for (const capture::FrameRecord& frame : session.Frames()) {
    if (frame.stream != "depth") continue;
    if (!root["rgbd_depth"]) {
      rig.storage.depth_units =
          frame.bits_per_sample == 32 ? capture::DepthUnits::kMetres : capture::DepthUnits::kMillimetres;
    }
    if (!root["rgbd_format"] && (frame.file_format == "png" || frame.file_format == "exr")) {
      rig.storage.rgbd_format = capture::RgbdFileFormat::kPng;
    }
    return;
  }
}

}  // namespace

RigConfig LoadRigConfig(const std::string& path, const std::optional<std::string>& scene_override) {
  const YamlFile file(path);
  const YAML::Node& root = file.root();
  file.RejectUnknownKeys(root, {"name", "scene", "site", "clock", "schedule", "duration_minutes", "bracket", "retry",
                                "rgbd_burst_frames", "rgbd_format", "rgbd_depth", "storage_faults", "devices"});
  RigConfig rig;
  rig.path = path;
  rig.name = file.RequireString(root, "name");
  rig.yaml_text = ReadInputFile(path);
  const RigDevices devices = ParseRigDevices(file, root, rig);
  ParseWorldAndSite(file, root, path, scene_override, devices, rig);
  rig.host_clock = devices.real_devices;
  if (rig.host_clock && root["clock"]) {
    file.Fail(root["clock"], "clock", "a rig with real devices runs on the host's clock; remove `clock:`");
  }
  ParseClock(file, root, rig);
  ParseSchedule(file, root, rig);
  ParseRecorderOptions(file, root, rig);
  ParseStorage(file, root, rig);
  StoreAsRecorded(root, devices, rig);
  ParseSimDevices(file, devices.sim_devices, rig);
  std::string why;
  if (!rig.recorder.IsValid(&why)) throw ConfigError(path, 0, "", why);
  return rig;
}

namespace {

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
    WriteText(folder / name, ReadInputFile(scene_folder / relative));
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
  if (std::filesystem::exists(folder / "scene.yaml")) {
    scene = (folder / "scene.yaml").string();
  } else if (YamlFile((folder / "rig.yaml").string()).root()["scene"]) {
    // The rig's own `scene:` path is relative to where it was recorded from; resolved here it
    // would read whatever lies there now, outside the session.
    throw IoError((folder / "scene.yaml").string(),
                  "is missing, although the session's rig names a scene: the session is incomplete (capture stores "
                  "the scene it recorded there). Restore the file from a copy of the session");
  }
  return std::make_shared<RigConfig>(LoadRigConfig((folder / "rig.yaml").string(), scene));
}

}  // namespace relume::rig
