// A rig file (config/rigs/*.yaml): which devices, where, on what schedule, and for simulated
// rigs the world they look at and the simulated clock.
//
//   name: sim-outdoor
//   scene: ../scenes/outdoor-building.yaml   # simulated rigs: the world (relative to this file)
//   clock: {start: 2026-06-21T07:00:00+03:00, mode: event}   # simulated clock: `event` (time
//          passes only while devices expose and the recorder waits) or `speedup: N` (N x real time)
//   schedule: {every_minutes: 120, start: ISO, end: ISO, count: N, sun_elevation_step_deg: X}
//   duration_minutes: 600                    # simulated minutes (optional)
//   bracket: {saturation_fraction, min_signal_fraction, overlap_stops, max_exposures}
//   retry: {max_attempts, initial_backoff_ms}
//   rgbd_burst_frames: 30                    # RGB-D frames per trigger (0 = stream continuously)
//   devices:                                 # sim device specs (sim/devices/sim_backend.h), where
//     - id: dslr                             # `scene_camera: NAME` may replace `camera:` to take
//       scene_camera: street                 # the pose, size and field of view of a scene camera
//       ...
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capture/recorder.h"
#include "core/site.h"
#include "sim/devices/sim_backend.h"
#include "sim/world/world.h"

namespace relume::app {

struct RigConfig {
  std::string path;
  std::string name;
  std::string yaml_text;  // the file, verbatim, for the session record
  Site site;
  std::shared_ptr<sim::World> world;  // simulated rigs
  UtcTime clock_start;
  double clock_speedup = 0.0;  // 0: event-driven clock
  capture::RecorderOptions recorder;
  int rgbd_burst_frames = 30;
  std::vector<sim::SimDeviceSpec> devices;
};

// Throws ConfigError / IoError naming the file, line and key.
RigConfig LoadRigConfig(const std::string& path);

}  // namespace relume::app
