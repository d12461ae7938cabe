// The "sim" device backend: simulated still cameras and RGB-D sensors, enumerated and opened
// through drivers::DeviceRegistry exactly like the real backends. All devices render from one
// shared TruthSource and run on one shared Clock; each has its own DeviceLink (faults.h), so an
// injected disconnect takes it out of Enumerate() until it reconnects.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/clock.h"
#include "drivers/backend.h"
#include "sim/devices/faults.h"
#include "sim/devices/sim_rgbd_sensor.h"
#include "sim/devices/sim_still_camera.h"
#include "sim/truth.h"

namespace relume::sim {

struct SimDeviceSpec {
  std::string id;
  std::string model = "relume simulated camera";
  std::string serial;
  drivers::DeviceKind kind = drivers::DeviceKind::kStillCamera;
  PinholeCamera camera;         // still: the camera; RGB-D: the depth camera at its native size
  SimStillCameraOptions still;  // kStillCamera
  SimRgbdOptions rgbd;          // kRgbdSensor
  FaultPlan faults;
};

class SimBackend : public drivers::Backend {
 public:
  // Throws InvalidArgumentError for duplicate or empty ids and invalid options.
  SimBackend(std::vector<SimDeviceSpec> devices, std::shared_ptr<const TruthSource> truth,
             std::shared_ptr<Clock> clock);
  std::string name() const override { return "sim"; }
  std::vector<drivers::DeviceInfo> Enumerate() override;
  std::unique_ptr<drivers::StillCamera> OpenStillCamera(const drivers::DeviceInfo& info) override;
  std::unique_ptr<drivers::RgbdSensor> OpenRgbdSensor(const drivers::DeviceInfo& info) override;

  // The connection state of a device (tests use it to look at or cause faults).
  std::shared_ptr<DeviceLink> link(const std::string& id) const;
  const std::vector<SimDeviceSpec>& devices() const { return devices_; }

 private:
  const SimDeviceSpec& SpecFor(const drivers::DeviceInfo& info, drivers::DeviceKind kind) const;
  drivers::DeviceInfo InfoFor(const SimDeviceSpec& spec) const;

  std::vector<SimDeviceSpec> devices_;
  std::map<std::string, std::shared_ptr<DeviceLink>> links_;
  std::shared_ptr<const TruthSource> truth_;
  std::shared_ptr<Clock> clock_;
};

// Reads device specs from YAML: a file that is one device (a mapping with `id`), or has a
// `devices:` list. Each device:
//   id, model, serial, kind (still_camera | rgbd_sensor)
//   camera: {width, height, horizontal_fov_deg | fx, fy, cx, cy,
//            position_m: [x, y, z], then look_at_m: [x, y, z] (+ up: [x, y, z]) or
//            rotation_wxyz: [w, x, y, z] (world_from_camera)}
//   exposure_control: shutter_list | continuous | ev_only        (still cameras)
//   output: raw | encoded, add_noise, readout_time_s, sensor_temperature_c,
//   initial_exposure: {exposure_time_s, aperture_f, iso, gain_db}
//   sensor: {full_well_e, electrons_per_j_per_sqm, read_noise_e, shot_noise, noise_seed,
//            raw_bits, black_level_fraction, layout (rgb | bayer_rggb), base_iso,
//            response: {shape: linear | gamma | filmic | table, gamma, contrast, values: [...]},
//            vignetting: {model: none | cos4 | polynomial, k1, k2, k3}}
//   metering: {statistic: median | mean, target_fraction, min_exposure_time_s, max_exposure_time_s}
//   device_clock: {offset_s, drift_ppm}
//   rgbd: {min_range_m, max_range_m, max_incidence_deg, edge_jump_fraction, noise,
//          disparity_step_px, depth_step_m, color_horizontal_fov_deg, baseline_m,
//          frame_jitter_s, queue_capacity, queue_full: drop_oldest | wait,
//          pacing: clock_sleep | follow_clock, seed, color_noise,
//          registration: nearest | interpolated (core/depth_registration.h) | none (no
//          hardware registration: only unregistered streams are offered)}
//   faults: see ParseFaultPlan (faults.h)
// Throws ConfigError naming file, line and key.
std::vector<SimDeviceSpec> LoadSimDeviceSpecs(const std::string& path);
std::vector<SimDeviceSpec> ParseSimDeviceSpecs(const YamlFile& file, const YAML::Node& devices_or_device);

// Resolves a device's `scene_camera: NAME` (rig files: the pose, size and field of view of a
// camera of the simulated world); throws relume::Error for a name the world does not have.
using SceneCameraLookup = std::function<PinholeCamera(const std::string& name)>;
// One device mapping, as above; with `scene_camera` given, `scene_camera: NAME` may replace
// `camera:`. Errors point at the device's own lines in `file`.
SimDeviceSpec ParseSimDevice(const YamlFile& file, const YAML::Node& device,
                             const SceneCameraLookup& scene_camera = {});

}  // namespace relume::sim
