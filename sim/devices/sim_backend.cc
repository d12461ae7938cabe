#include "sim/devices/sim_backend.h"

#include <cmath>
#include <set>

#include "core/site.h"
#include "drivers/device_error.h"

namespace relume::sim {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::DeviceInfo;
using drivers::DeviceKind;

SimBackend::SimBackend(std::vector<SimDeviceSpec> devices, std::shared_ptr<const TruthSource> truth,
                       std::shared_ptr<Clock> clock)
    : devices_(std::move(devices)), truth_(std::move(truth)), clock_(std::move(clock)) {
  RELUME_CHECK(truth_ != nullptr && clock_ != nullptr);
  std::set<std::string> ids;
  for (const SimDeviceSpec& spec : devices_) {
    if (spec.id.empty()) throw InvalidArgumentError("sim backend: a device has an empty id");
    if (!ids.insert(spec.id).second)
      throw InvalidArgumentError("sim backend: device id '" + spec.id + "' is used twice");
    const std::string what = "sim device " + spec.id;
    ThrowIfInvalid(spec.camera.intrinsics, (what + " camera").c_str());
    if (spec.kind == DeviceKind::kStillCamera) {
      ThrowIfInvalid(spec.still, what.c_str());
    } else {
      ThrowIfInvalid(spec.rgbd, what.c_str());
    }
    links_[spec.id] = std::make_shared<DeviceLink>(spec.faults, clock_);
  }
}

DeviceInfo SimBackend::InfoFor(const SimDeviceSpec& spec) const {
  DeviceInfo info;
  info.backend = name();
  info.id = spec.id;
  info.kind = spec.kind;
  info.model = spec.model;
  info.serial = spec.serial.empty() ? "SIM-" + spec.id : spec.serial;
  info.address = "sim://" + spec.id;
  info.details["clock"] = clock_->name();
  if (spec.kind == DeviceKind::kStillCamera) {
    info.details["exposure_control"] = drivers::ToString(spec.still.control);
    info.details["raw_bits"] = std::to_string(spec.still.model.raw_bits);
    info.details["response"] = ToString(spec.still.model.response.shape);
  }
  info.details["size"] =
      std::to_string(spec.camera.intrinsics.width) + "x" + std::to_string(spec.camera.intrinsics.height);
  if (!spec.faults.empty()) info.details["faults"] = "injected";
  return info;
}

std::vector<DeviceInfo> SimBackend::Enumerate() {
  std::vector<DeviceInfo> found;
  for (const SimDeviceSpec& spec : devices_) {
    if (links_.at(spec.id)->Present()) found.push_back(InfoFor(spec));
  }
  return found;
}

std::shared_ptr<DeviceLink> SimBackend::link(const std::string& id) const {
  const auto it = links_.find(id);
  return it == links_.end() ? nullptr : it->second;
}

const SimDeviceSpec& SimBackend::SpecFor(const DeviceInfo& info, DeviceKind kind) const {
  for (const SimDeviceSpec& spec : devices_) {
    if (spec.id != info.id) continue;
    if (!links_.at(spec.id)->Present())
      throw DeviceError(DeviceErrorKind::kNotFound, info.FullId(), "the device is unplugged (not enumerated)");
    if (spec.kind != kind)
      throw InvalidArgumentError(info.FullId() + " is a " + drivers::ToString(spec.kind) + ", not a " +
                                 drivers::ToString(kind));
    return spec;
  }
  throw DeviceError(DeviceErrorKind::kNotFound, info.FullId(), "no simulated device with that id");
}

std::unique_ptr<drivers::StillCamera> SimBackend::OpenStillCamera(const DeviceInfo& info) {
  const SimDeviceSpec& spec = SpecFor(info, DeviceKind::kStillCamera);
  return std::make_unique<SimStillCamera>(InfoFor(spec), spec.still, spec.camera, truth_, clock_, links_.at(spec.id));
}

std::unique_ptr<drivers::RgbdSensor> SimBackend::OpenRgbdSensor(const DeviceInfo& info) {
  const SimDeviceSpec& spec = SpecFor(info, DeviceKind::kRgbdSensor);
  return std::make_unique<SimRgbdSensor>(InfoFor(spec), spec.rgbd, spec.camera, truth_, clock_, links_.at(spec.id));
}

// ---- YAML ----

namespace {

Eigen::Vector3d RequireVector3(const YamlFile& file, const YAML::Node& map, const std::string& key) {
  const YAML::Node value = map[key];
  if (!value || !value.IsSequence() || value.size() != 3) file.Fail(value ? value : map, key, "expected [x, y, z]");
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!YAML::convert<double>::decode(value[i], v[i]) || !std::isfinite(v[i]))
      file.Fail(value, key, "expected three finite numbers");
  }
  return v;
}

double Optional(const YamlFile& file, const YAML::Node& map, const std::string& key, double fallback) {
  return map[key] ? file.RequireDouble(map, key) : fallback;
}

bool OptionalBool(const YamlFile& file, const YAML::Node& map, const std::string& key, bool fallback) {
  const YAML::Node value = map[key];
  if (!value) return fallback;
  bool result = false;
  if (!value.IsScalar() || !YAML::convert<bool>::decode(value, result)) file.Fail(value, key, "expected true or false");
  return result;
}

template <typename Enum>
Enum Choose(const YamlFile& file, const YAML::Node& map, const std::string& key,
            std::initializer_list<std::pair<const char*, Enum>> choices, Enum fallback) {
  if (!map[key]) return fallback;
  const std::string text = file.RequireString(map, key);
  std::string list;
  for (const auto& [name, value] : choices) {
    if (text == name) return value;
    list += std::string(list.empty() ? "" : ", ") + name;
  }
  file.Fail(map[key], key, "'" + text + "' is not one of: " + list);
}

PinholeCamera ParseCamera(const YamlFile& file, const YAML::Node& node) {
  if (!node || !node.IsMap())
    file.Fail(node, "camera", "expected a mapping with width, height, field of view and pose");
  file.RejectUnknownKeys(node, {"width", "height", "horizontal_fov_deg", "fx", "fy", "cx", "cy", "position_m",
                                "look_at_m", "up", "rotation_wxyz"});
  const double width = file.RequireDouble(node, "width"), height = file.RequireDouble(node, "height");
  if (width < 1 || height < 1 || width != std::floor(width) || height != std::floor(height) || width > 100000 ||
      height > 100000)
    file.Fail(node, "width", "width and height must be positive integers");
  PinholeIntrinsics k;
  if (node["horizontal_fov_deg"]) {
    const double fov = file.RequireDouble(node, "horizontal_fov_deg");
    if (!(fov > 0.0 && fov < 180.0)) file.Fail(node["horizontal_fov_deg"], "horizontal_fov_deg", "must be in (0, 180)");
    k = PinholeIntrinsics::FromHorizontalFov(static_cast<int>(width), static_cast<int>(height), DegToRad(fov));
  } else {
    k.width = static_cast<int>(width);
    k.height = static_cast<int>(height);
    k.fx = file.RequireDouble(node, "fx");
    k.fy = file.RequireDouble(node, "fy");
    k.cx = Optional(file, node, "cx", width / 2);
    k.cy = Optional(file, node, "cy", height / 2);
  }
  std::string why;
  if (!k.IsValid(&why)) file.Fail(node, "camera", why);
  const Eigen::Vector3d position = RequireVector3(file, node, "position_m");
  if (node["look_at_m"]) {
    const Eigen::Vector3d target = RequireVector3(file, node, "look_at_m");
    const Eigen::Vector3d up = node["up"] ? RequireVector3(file, node, "up") : Eigen::Vector3d::UnitZ();
    if ((target - position).norm() < 1e-9 || (target - position).normalized().cross(up.normalized()).norm() < 1e-6)
      file.Fail(node["look_at_m"], "look_at_m", "must differ from position_m and not be along `up`");
    return PinholeCamera::LookAt(k, position, target, up);
  }
  const YAML::Node q = node["rotation_wxyz"];
  if (!q || !q.IsSequence() || q.size() != 4)
    file.Fail(node, "rotation_wxyz", "give look_at_m or rotation_wxyz: [w, x, y, z]");
  double wxyz[4];
  for (int i = 0; i < 4; ++i) {
    if (!YAML::convert<double>::decode(q[i], wxyz[i]) || !std::isfinite(wxyz[i]))
      file.Fail(q, "rotation_wxyz", "expected four finite numbers");
  }
  Eigen::Quaterniond rotation(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  if (rotation.norm() < 1e-9) file.Fail(q, "rotation_wxyz", "a zero quaternion is not a rotation");
  PinholeCamera camera;
  camera.intrinsics = k;
  camera.world_from_camera = Eigen::Translation3d(position) * rotation.normalized();
  return camera;
}

ResponseCurve ParseResponse(const YamlFile& file, const YAML::Node& node) {
  file.RejectUnknownKeys(node, {"shape", "gamma", "contrast", "values"});
  ResponseCurve curve;
  curve.shape = Choose<ResponseCurve::Shape>(file, node, "shape",
                                             {{"linear", ResponseCurve::Shape::kLinear},
                                              {"gamma", ResponseCurve::Shape::kGamma},
                                              {"filmic", ResponseCurve::Shape::kFilmic},
                                              {"table", ResponseCurve::Shape::kTable}},
                                             ResponseCurve::Shape::kGamma);
  curve.gamma = Optional(file, node, "gamma", curve.gamma);
  curve.contrast = Optional(file, node, "contrast", curve.contrast);
  if (const YAML::Node values = node["values"]) {
    if (!values.IsSequence()) file.Fail(values, "values", "expected a list of numbers in [0, 1]");
    for (const YAML::Node& v : values) {
      double number = 0.0;
      if (!YAML::convert<double>::decode(v, number)) file.Fail(v, "values", "expected a number");
      curve.table.push_back(number);
    }
  }
  std::string why;
  if (!curve.IsValid(&why)) file.Fail(node, "response", why);
  return curve;
}

CameraModelOptions ParseSensor(const YamlFile& file, const YAML::Node& node, CameraModelOptions model) {
  file.RejectUnknownKeys(node, {"full_well_e", "electrons_per_j_per_sqm", "read_noise_e", "shot_noise", "noise_seed",
                                "raw_bits", "black_level_fraction", "layout", "base_iso", "response", "vignetting"});
  model.full_well_e = Optional(file, node, "full_well_e", model.full_well_e);
  model.electrons_per_j_per_sqm = Optional(file, node, "electrons_per_j_per_sqm", model.electrons_per_j_per_sqm);
  model.read_noise_e = Optional(file, node, "read_noise_e", model.read_noise_e);
  model.shot_noise = OptionalBool(file, node, "shot_noise", model.shot_noise);
  model.noise_seed =
      static_cast<std::uint64_t>(Optional(file, node, "noise_seed", static_cast<double>(model.noise_seed)));
  if (node["raw_bits"]) model.raw_bits = file.RequireInt(node, "raw_bits", 8, 16);
  model.black_level_fraction = Optional(file, node, "black_level_fraction", model.black_level_fraction);
  model.raw_layout = Choose<ColorLayout>(
      file, node, "layout", {{"rgb", ColorLayout::kRgb}, {"bayer_rggb", ColorLayout::kBayerRggb}}, model.raw_layout);
  model.base_iso = Optional(file, node, "base_iso", model.base_iso);
  if (node["response"]) model.response = ParseResponse(file, node["response"]);
  if (const YAML::Node v = node["vignetting"]) {
    file.RejectUnknownKeys(v, {"model", "k1", "k2", "k3"});
    model.vignetting.model = Choose<Vignetting::Model>(file, v, "model",
                                                       {{"none", Vignetting::Model::kNone},
                                                        {"cos4", Vignetting::Model::kCos4},
                                                        {"polynomial", Vignetting::Model::kPolynomial}},
                                                       Vignetting::Model::kNone);
    model.vignetting.k1 = Optional(file, v, "k1", 0.0);
    model.vignetting.k2 = Optional(file, v, "k2", 0.0);
    model.vignetting.k3 = Optional(file, v, "k3", 0.0);
  }
  std::string why;
  if (!model.IsValid(&why)) file.Fail(node, "sensor", why);
  return model;
}

void ParseRgbd(const YamlFile& file, const YAML::Node& node, SimRgbdOptions& rgbd) {
  file.RejectUnknownKeys(
      node, {"min_range_m", "max_range_m", "max_incidence_deg", "edge_jump_fraction", "noise", "disparity_step_px",
             "depth_step_m", "color_horizontal_fov_deg", "baseline_m", "frame_jitter_s", "queue_capacity", "queue_full",
             "pacing", "seed", "color_noise", "registration"});
  rgbd.depth.min_range_m = Optional(file, node, "min_range_m", rgbd.depth.min_range_m);
  rgbd.depth.max_range_m = Optional(file, node, "max_range_m", rgbd.depth.max_range_m);
  rgbd.depth.max_incidence_rad =
      DegToRad(Optional(file, node, "max_incidence_deg", RadToDeg(rgbd.depth.max_incidence_rad)));
  rgbd.depth.edge_jump_fraction = Optional(file, node, "edge_jump_fraction", rgbd.depth.edge_jump_fraction);
  rgbd.depth.noise = OptionalBool(file, node, "noise", rgbd.depth.noise);
  rgbd.depth.disparity_step_px = Optional(file, node, "disparity_step_px", rgbd.depth.disparity_step_px);
  rgbd.depth.depth_step_m = Optional(file, node, "depth_step_m", rgbd.depth.depth_step_m);
  rgbd.color_noise = OptionalBool(file, node, "color_noise", rgbd.color_noise);
  rgbd.color_horizontal_fov_rad =
      DegToRad(Optional(file, node, "color_horizontal_fov_deg", RadToDeg(rgbd.color_horizontal_fov_rad)));
  if (node["baseline_m"]) {
    rgbd.color_from_depth = Eigen::Translation3d(-file.RequireDouble(node, "baseline_m"), 0.0, 0.0);
  }
  if (node["registration"] && node["registration"].IsScalar() && node["registration"].as<std::string>() == "none") {
    // A sensor without hardware registration (Kinect v2- or Azure Kinect-like): it offers only
    // unregistered streams, and processing registers depth from the recorded geometry.
    std::erase_if(rgbd.configs, [](const drivers::RgbdStreamConfig& c) { return c.register_depth_to_color; });
  } else {
    rgbd.registration = Choose<Registration>(
        file, node, "registration",
        {{"nearest", Registration::kNearest}, {"interpolated", Registration::kInterpolated}}, rgbd.registration);
  }
  rgbd.frame_jitter_s = Optional(file, node, "frame_jitter_s", rgbd.frame_jitter_s);
  if (node["queue_capacity"]) rgbd.queue_capacity = file.RequireInt(node, "queue_capacity", 1, 1000);
  rgbd.queue_full = Choose<SimRgbdOptions::QueueFull>(
      file, node, "queue_full",
      {{"drop_oldest", SimRgbdOptions::QueueFull::kDropOldest}, {"wait", SimRgbdOptions::QueueFull::kWait}},
      rgbd.queue_full);
  rgbd.pacing = Choose<SimRgbdOptions::Pacing>(
      file, node, "pacing",
      {{"clock_sleep", SimRgbdOptions::Pacing::kClockSleep}, {"follow_clock", SimRgbdOptions::Pacing::kFollowClock}},
      rgbd.pacing);
  rgbd.seed = static_cast<std::uint64_t>(Optional(file, node, "seed", static_cast<double>(rgbd.seed)));
}

PinholeCamera ParseDeviceCamera(const YamlFile& file, const YAML::Node& node, const SceneCameraLookup& scene_camera) {
  const YAML::Node name = node["scene_camera"];
  if (!name) return ParseCamera(file, node["camera"]);
  if (!scene_camera) file.Fail(name, "scene_camera", "scene cameras are for rig files (with a scene); give camera:");
  if (node["camera"]) file.Fail(node, "scene_camera", "give either scene_camera or camera, not both");
  const std::string text = file.RequireString(node, "scene_camera");
  try {
    return scene_camera(text);
  } catch (const Error& e) {
    file.Fail(name, "scene_camera", e.what());
  }
}

SimDeviceSpec ParseDevice(const YamlFile& file, const YAML::Node& node, const SceneCameraLookup& scene_camera = {}) {
  if (!node.IsMap()) file.Fail(node, "devices", "each device is a mapping with at least id, kind and camera");
  file.RejectUnknownKeys(node, {"id", "model", "serial", "kind", "camera", "scene_camera", "exposure_control", "output",
                                "add_noise", "readout_time_s", "sensor_temperature_c", "initial_exposure", "sensor",
                                "metering", "device_clock", "rgbd", "faults"});
  SimDeviceSpec spec;
  spec.id = file.RequireString(node, "id");
  if (node["model"]) spec.model = file.RequireString(node, "model");
  if (node["serial"]) spec.serial = file.RequireString(node, "serial");
  spec.kind = Choose<DeviceKind>(file, node, "kind",
                                 {{"still_camera", DeviceKind::kStillCamera}, {"rgbd_sensor", DeviceKind::kRgbdSensor}},
                                 DeviceKind::kStillCamera);
  spec.camera = ParseDeviceCamera(file, node, scene_camera);
  const auto control = Choose<drivers::ExposureControl>(file, node, "exposure_control",
                                                        {{"shutter_list", drivers::ExposureControl::kShutterList},
                                                         {"continuous", drivers::ExposureControl::kContinuous},
                                                         {"ev_only", drivers::ExposureControl::kEvOnly}},
                                                        drivers::ExposureControl::kShutterList);
  spec.still = SimStillCameraOptions::ForControl(control);
  spec.still.output = Choose<SimStillCameraOptions::Output>(
      file, node, "output",
      {{"raw", SimStillCameraOptions::Output::kRaw}, {"encoded", SimStillCameraOptions::Output::kEncoded}},
      spec.still.output);
  spec.still.add_noise = OptionalBool(file, node, "add_noise", spec.still.add_noise);
  spec.still.readout_time_s = Optional(file, node, "readout_time_s", spec.still.readout_time_s);
  if (node["sensor_temperature_c"]) spec.still.sensor_temperature_c = file.RequireDouble(node, "sensor_temperature_c");
  if (const YAML::Node e = node["initial_exposure"]) {
    file.RejectUnknownKeys(e, {"exposure_time_s", "aperture_f", "iso", "gain_db"});
    ExposureParams& x = spec.still.initial_exposure;
    x.exposure_time_s = Optional(file, e, "exposure_time_s", x.exposure_time_s);
    x.aperture_f = Optional(file, e, "aperture_f", x.aperture_f);
    x.iso = Optional(file, e, "iso", x.iso);
    x.gain_db = Optional(file, e, "gain_db", x.gain_db);
    std::string why;
    if (!x.IsValid(&why)) file.Fail(e, "initial_exposure", why);
  }
  if (const YAML::Node s = node["sensor"]) {
    if (spec.kind == DeviceKind::kStillCamera) {
      spec.still.model = ParseSensor(file, s, spec.still.model);
    } else {
      spec.rgbd.color_model = ParseSensor(file, s, spec.rgbd.color_model);
    }
  }
  if (const YAML::Node m = node["metering"]) {
    file.RejectUnknownKeys(m, {"statistic", "target_fraction", "min_exposure_time_s", "max_exposure_time_s"});
    MeteringOptions& metering = spec.still.metering;
    metering.statistic = Choose<MeteringOptions::Statistic>(
        file, m, "statistic",
        {{"median", MeteringOptions::Statistic::kMedian}, {"mean", MeteringOptions::Statistic::kMean}},
        metering.statistic);
    metering.target_fraction = Optional(file, m, "target_fraction", metering.target_fraction);
    metering.min_exposure_time_s = Optional(file, m, "min_exposure_time_s", metering.min_exposure_time_s);
    metering.max_exposure_time_s = Optional(file, m, "max_exposure_time_s", metering.max_exposure_time_s);
  }
  if (const YAML::Node c = node["device_clock"]) {
    file.RejectUnknownKeys(c, {"offset_s", "drift_ppm"});
    DeviceClockOptions clock{Optional(file, c, "offset_s", 0.0), Optional(file, c, "drift_ppm", 0.0)};
    spec.still.device_clock = spec.rgbd.device_clock = clock;
  }
  if (const YAML::Node r = node["rgbd"]) ParseRgbd(file, r, spec.rgbd);
  if (const YAML::Node f = node["faults"]) spec.faults = ParseFaultPlan(file, f);
  std::string why;
  if (spec.kind == DeviceKind::kStillCamera ? !spec.still.IsValid(&why) : !spec.rgbd.IsValid(&why))
    file.Fail(node, spec.id, why);
  return spec;
}

}  // namespace

std::vector<SimDeviceSpec> ParseSimDeviceSpecs(const YamlFile& file, const YAML::Node& node) {
  std::vector<SimDeviceSpec> specs;
  if (node.IsMap() && node["devices"]) {
    const YAML::Node list = node["devices"];
    if (!list.IsSequence()) file.Fail(list, "devices", "expected a list of devices");
    for (const YAML::Node& device : list) specs.push_back(ParseDevice(file, device));
  } else if (node.IsMap() && node["id"]) {
    specs.push_back(ParseDevice(file, node));
  } else {
    file.Fail(node, "devices", "expected a `devices:` list or a single device with an `id`");
  }
  std::set<std::string> ids;
  for (const SimDeviceSpec& spec : specs) {
    if (!ids.insert(spec.id).second) file.Fail(node, spec.id, "device id used twice");
  }
  return specs;
}

SimDeviceSpec ParseSimDevice(const YamlFile& file, const YAML::Node& device, const SceneCameraLookup& scene_camera) {
  return ParseDevice(file, device, scene_camera);
}

std::vector<SimDeviceSpec> LoadSimDeviceSpecs(const std::string& path) {
  const YamlFile file(path);
  return ParseSimDeviceSpecs(file, file.root());
}

}  // namespace relume::sim
