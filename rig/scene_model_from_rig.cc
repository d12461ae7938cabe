#include "rig/scene_model_from_rig.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"

namespace relume::rig {

namespace {

constexpr int kMaxTrackEntries = 20000;

// The instants where a motion's offset is not linear in time between neighbours, within [from, to].
std::vector<UtcTime> TrackTimes(const sim::Motion& motion, UtcTime from, UtcTime to) {
  std::set<UtcTime> times{from, to};
  switch (motion.type) {
    case sim::Motion::Type::kStatic: return {from};
    case sim::Motion::Type::kLinear: break;
    case sim::Motion::Type::kPath:
      for (const sim::Motion::Waypoint& w : motion.waypoints) {
        const UtcTime t =
            motion.reference_time + std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(w.t_s));
        if (t > from && t < to) times.insert(t);
      }
      break;
    case sim::Motion::Type::kCircular: {
      const double span_s = std::chrono::duration<double>(to - from).count();
      const int steps =
          std::clamp(static_cast<int>(std::ceil(720.0 * span_s / motion.period_s)), 1, kMaxTrackEntries - 1);
      for (int i = 1; i < steps; ++i) {
        times.insert(from + std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(span_s * i / steps)));
      }
      break;
    }
  }
  return {times.begin(), times.end()};
}

SceneModelLamp LampFrom(const sim::Lamp& lamp, UtcTime from, UtcTime to) {
  SceneModelLamp out;
  out.name = lamp.name;
  out.type = lamp.type == sim::Lamp::Type::kSpot ? SceneModelLamp::Type::kSpot : SceneModelLamp::Type::kPoint;
  out.intensity_w_sr = lamp.intensity_w_sr;
  out.direction = lamp.direction.normalized();
  if (lamp.type == sim::Lamp::Type::kSpot) {
    out.cone_half_angle_rad = lamp.cone_half_angle_rad;
    out.falloff_rad = lamp.falloff_rad;
  }
  for (UtcTime t : TrackTimes(lamp.motion, from, to)) {
    out.track.push_back({t, lamp.position + lamp.motion.OffsetAt(t, lamp.position)});
  }
  return out;
}

int AddMaterial(SceneModel* model, const std::string& name, std::optional<Eigen::Vector3d> albedo) {
  model->materials.push_back({name, albedo});
  return static_cast<int>(model->materials.size()) - 1;
}

SceneModelObject ObjectFrom(const sim::SceneObject& object, SceneModel* model) {
  SceneModelObject out;
  out.name = object.name;
  const int own = AddMaterial(model, object.name, std::nullopt);
  if (object.shape == sim::SceneObject::Shape::kSphere) {
    out.kind = SceneModelObject::Kind::kSphere;
    out.sphere_center = object.sphere_center;
    out.sphere_radius_m = object.sphere_radius_m;
    out.material = own;
    return out;
  }
  out.kind = object.shape == sim::SceneObject::Shape::kPlane ? SceneModelObject::Kind::kSurface
                                                             : SceneModelObject::Kind::kSolid;
  out.vertices = object.mesh.vertices;
  out.triangles = object.mesh.triangles;
  out.face_material.assign(out.triangles.size(), own);
  if (object.colorchecker) {
    // The patches' reference reflectance (what the chart's data sheet gives); the frame stays unknown.
    const sim::ColorCheckerLayout& layout = *object.colorchecker;
    std::map<std::size_t, int> patch_material;
    for (std::size_t f = 0; f < object.mesh.face_albedo.size(); ++f) {
      const Eigen::Vector3d& a = object.mesh.face_albedo[f];
      for (std::size_t p = 0; p < layout.albedo.size(); ++p) {
        if (!a.allFinite() || !(a - layout.albedo[p]).isZero(0.0)) continue;
        auto it = patch_material.find(p);
        if (it == patch_material.end()) {
          it = patch_material.emplace(p, AddMaterial(model, object.name + "/" + layout.names[p], layout.albedo[p]))
                   .first;
        }
        out.face_material[f] = it->second;
        break;
      }
    }
  }
  return out;
}

}  // namespace

SceneModel SceneModelFromSimScene(const sim::Scene& scene, const std::string& source, UtcTime from, UtcTime to) {
  SceneModel model;
  model.source = source;
  model.site = scene.site;
  for (const sim::SceneObject& object : scene.objects) model.objects.push_back(ObjectFrom(object, &model));
  for (const sim::Lamp& lamp : scene.lamps) model.lamps.push_back(LampFrom(lamp, from, to));
  return model;
}

std::pair<UtcTime, UtcTime> RigCaptureWindow(const RigConfig& rig) {
  const capture::ScheduleOptions& s = rig.recorder.schedule;
  const UtcTime start = s.start.value_or(rig.clock_start);
  UtcTime end = start + std::chrono::hours(24);
  if (s.end) {
    end = *s.end;
  } else if (s.count > 0 && s.kind != capture::ScheduleOptions::Kind::kSunElevationStep) {
    end = start + s.count * s.interval;
  }
  if (rig.recorder.duration) end = std::min(end, rig.clock_start + *rig.recorder.duration);
  const UtcTime from = std::min(rig.clock_start, start) - std::chrono::minutes(1);
  return {from, std::max(end, start) + std::chrono::minutes(1)};
}

SceneModel SceneModelFromRig(const RigConfig& rig, UtcTime from, UtcTime to) {
  if (!rig.world) {
    throw InvalidArgumentError("rig '" + rig.name + "' has no simulated world to describe (" + rig.path + ")");
  }
  SceneModel model = SceneModelFromSimScene(
      rig.world->scene(), "simulated rig '" + rig.name + "' (its world: " + rig.scene_path + ")", from, to);
  model.site = rig.site;
  for (const sim::SimDeviceSpec& spec : rig.devices) {
    SceneModelCamera camera;
    camera.device_id = "sim:" + spec.id;
    camera.camera = spec.camera;
    if (spec.kind == drivers::DeviceKind::kRgbdSensor) {
      // Its colour camera (registered depth lies in its frame), at the depth camera's native size.
      camera.camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(
          spec.camera.intrinsics.width, spec.camera.intrinsics.height, spec.rgbd.color_horizontal_fov_rad);
      camera.camera.world_from_camera = spec.camera.world_from_camera * spec.rgbd.color_from_depth.inverse();
    }
    camera.source = "simulated rig '" + rig.name + "': the device's placement in the rig file";
    model.cameras.push_back(camera);
  }
  std::string why;
  if (!model.IsValid(&why)) throw InvalidArgumentError("the scene model of rig '" + rig.name + "': " + why);
  return model;
}

SceneModel SceneModelFromRig(const RigConfig& rig) {
  const auto [from, to] = RigCaptureWindow(rig);
  return SceneModelFromRig(rig, from, to);
}

std::int64_t AddSceneModelFromStoredRig(const std::filesystem::path& session_dir) {
  std::int64_t existing = 0;
  UtcTime first = UtcTime::max(), last = UtcTime::min();
  {
    const capture::SessionReader reader(session_dir);
    const std::vector<capture::CalibrationRecord> rows = reader.Calibrations();
    if (const capture::CalibrationRecord* row = capture::LatestSceneModelRow(rows)) existing = row->id;
    for (const capture::FrameRecord& f : reader.Frames()) {
      first = std::min(first, f.utc);
      last = std::max(last, f.utc);
    }
  }
  if (existing > 0) {
    throw InvalidArgumentError("session " + session_dir.string() + " already has a scene model (calibration row " +
                               std::to_string(existing) + "); nothing to add");
  }
  const std::shared_ptr<RigConfig> rig = LoadSessionRig(session_dir);
  if (rig == nullptr || !rig->world) {
    throw InvalidArgumentError("session " + session_dir.string() +
                               " keeps no simulated rig and world (<session>/rig/) to describe; a real session gets "
                               "its scene model from calibration and import (docs/real-data.md)");
  }
  auto [from, to] = RigCaptureWindow(*rig);
  if (first <= last) {
    from = std::min(from, first - std::chrono::minutes(1));
    to = std::max(to, last + std::chrono::minutes(1));
  }
  const SceneModel model = SceneModelFromRig(*rig, from, to);
  return capture::StoreSceneModel(session_dir, model);
}

}  // namespace relume::rig
