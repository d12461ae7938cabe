// A rig file (config/rigs/*.yaml): which devices, where, on what schedule, and for simulated
// rigs the world they look at and the simulated clock.
//
//   name: sim-outdoor
//   scene: ../scenes/outdoor-building.yaml   # simulated rigs: the world (relative to this file)
//   clock: {start: 2026-06-21T07:00:00+03:00, mode: event}   # simulated clock: `event` (time
//          passes only while devices expose and the recorder waits) or `speedup: N` (N x real time);
//          without `start`, the clock starts at the schedule's start, else at the scene's time
//   schedule: {every_minutes: 120, start: ISO, end: ISO, count: N, sun_elevation_step_deg: X}
//   duration_minutes: 600                    # simulated minutes (optional)
//   bracket: {saturation_fraction, min_signal_fraction, overlap_stops, max_exposures}
//   retry: {max_attempts, initial_backoff_ms}
//   rgbd_burst_frames: 30                    # RGB-D frames per trigger (0 = stream continuously)
//   rgbd_format: tiff                        # RGB-D files: tiff (zstd, default) or png
//   rgbd_depth: millimetres                  # depth: millimetres (16-bit, default) or metres (float)
//                                            # (rigs playing a session back: as it was recorded)
//   devices:                                 # sim device specs (sim/devices/sim_backend.h), where
//     - id: dslr                             # `scene_camera: NAME` may replace `camera:` to take
//       scene_camera: street                 # the pose, size and field of view of a scene camera
//       ...
//     - backend: gphoto2                     # a real device, opened through the registry and
//       model: "Nikon DSC D750"              # matched by the keys given: id, model, port,
//       port: "usb:001,007"                  # serial, uri (see RegistryDeviceSpec); a rig with
//     - backend: openni2                     # real devices runs on the host clock and needs
//       uri: "1d27/0601@1/5"                 # `site: FILE` (no simulated world to take it from)
//       stream: {depth: 640x480, fps: 30}    # RGB-D: which of the sensor's streams (RgbdStreamRequest)
//     - backend: gphoto2
//       model: "Nikon DSC D750"
//       settings: {imageformat: RAW}         # gphoto2: configuration values set at every open
//     - backend: playback                    # a recorded session's device played back
//       session: ../sessions/monday          # (capture/playback.h), relative to this file
//       device: sim:dslr
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "capture/recorder.h"
#include "capture/session.h"
#include "core/site.h"
#include "drivers/rgbd_sensor.h"
#include "sim/devices/sim_backend.h"
#include "sim/world/world.h"

namespace relume::rig {

// Which of an RGB-D sensor's streams a rig asks for; unset keys match anything. The capture
// records the first of the sensor's SupportedConfigs() that matches every key given.
//   stream: {depth: 640x480, color: 1280x960, fps: 30, registered: true, synced: true}
struct RgbdStreamRequest {
  std::optional<std::pair<int, int>> depth_size, color_size;  // width, height
  std::optional<double> fps;
  std::optional<bool> registered, synced;
  bool Matches(const drivers::RgbdStreamConfig& config) const;
  std::string Describe() const;  // "depth 640x480, fps 30"
};

// A device of the rig that is opened through the device registry (not simulated here).
struct RegistryDeviceSpec {
  std::string backend;  // "gphoto2", "aravis", "openni2", "playback"
  // Match keys: every one given must equal the enumerated device's (port and uri compare with
  // DeviceInfo::address, id with DeviceInfo::id).
  std::string id, model, serial, port, uri;
  std::string session;  // playback: the recorded session folder (resolved against the rig file)
  std::string device;   // playback: the recorded device's full id ("sim:dslr")
  // gphoto2: camera configuration values set whenever the camera is opened, in the order given
  // (`settings: {imageformat: RAW, iso: "100"}`; names and values as `relume devices` shows them).
  std::vector<std::pair<std::string, std::string>> camera_settings;
  std::optional<RgbdStreamRequest> stream;  // RGB-D devices (openni2, playback)
  int line = 0;                             // in the rig file, for messages
  std::string Describe() const;             // "gphoto2 device (model \"X\", port \"Y\") at rig.yaml:12"
};

struct RigConfig {
  std::string path;
  std::string scene_path;  // the simulated world's scene file
  std::string name;
  std::string yaml_text;  // the file, verbatim, for the session record
  Site site;
  std::shared_ptr<sim::World> world;  // simulated rigs
  UtcTime clock_start;
  double clock_speedup = 0.0;  // 0: event-driven clock
  capture::RecorderOptions recorder;
  int rgbd_burst_frames = 30;
  capture::SessionWriterOptions storage;    // `rgbd_format:`, `rgbd_depth:`
  std::vector<sim::SimDeviceSpec> devices;  // simulated devices (need `scene:`)
  std::vector<RegistryDeviceSpec> registry_devices;
  // Which clock: simulated rigs and playback-only rigs run on a simulated clock; rigs with
  // real devices on the host's clock (`clock:` is then refused).
  bool host_clock = false;
};

// Throws ConfigError / IoError naming the file, line and key. `scene_override` replaces the
// file's `scene:` path (a session's own copy of the world, see LoadSessionRig).
RigConfig LoadRigConfig(const std::string& path, const std::optional<std::string>& scene_override = std::nullopt);

// A session keeps the rig it was recorded with, and for simulated rigs the world it looked at,
// in <session>/rig/: rig.yaml (verbatim), scene.yaml (with the meshes and chart references it
// names copied into files/ and its paths pointed there). This is what lets processing find the
// geometry, the cameras and (for simulated sessions) the ground truth later, without the config
// folder the capture ran from. Files are written durably.
void StoreRigWithSession(const RigConfig& rig, const std::filesystem::path& session_dir);
// The rig stored with a session, or null when the session has none (recorded before rigs
// were stored). Errors in the stored files are reported like LoadRigConfig's.
std::shared_ptr<RigConfig> LoadSessionRig(const std::filesystem::path& session_dir);

}  // namespace relume::rig
