// The scene model (core/scene_model.h) of a simulated rig: what a field team would have
// measured of the same place, written into the session by capture so that processing reads
// the scene from the session and never from the simulator.
//
// What goes in, and what stays in the simulator:
//  - Cameras: each simulated device's intrinsics and pose (an RGB-D sensor's colour camera, at
//    its depth camera's native size).
//  - Objects at their described places: planes as surfaces, boxes, meshes and charts as solids,
//    spheres as spheres. Materials: one per object, albedo unknown; a ColorChecker's patches
//    (faces with their own albedo) get one material each with the chart's reference reflectance,
//    which a field team knows from the chart's data sheet. No other true albedo is written.
//  - Lamps: type, stated intensity, spot cone, and a track of where they stood over
//    [from, to]: exact for static lamps, path and linear motions (their waypoints, or their two
//    ends), sampled 720 times a turn for circular ones (at most 20000 entries).
//  - Not written: the sun and sky (processing takes the sun from each frame's row and
//    estimates the rest), the render settings, sensor models and object motions.
#pragma once

#include <filesystem>
#include <string>

#include "core/scene_model.h"
#include "rig/rig_config.h"

namespace relume::rig {

SceneModel SceneModelFromSimScene(const sim::Scene& scene, const std::string& source, UtcTime from, UtcTime to);

// The rig's world and its simulated devices' cameras, lamps tracked over the rig's capture
// window (RigCaptureWindow). Throws InvalidArgumentError for a rig with no simulated world.
SceneModel SceneModelFromRig(const RigConfig& rig);
// The same with lamps tracked over [from, to].
SceneModel SceneModelFromRig(const RigConfig& rig, UtcTime from, UtcTime to);

// [clock start - 1 min, the schedule's end or its count of intervals, or the recorder's
// duration, + 1 min]; a day when nothing bounds the capture.
std::pair<UtcTime, UtcTime> RigCaptureWindow(const RigConfig& rig);

// For a session captured from a simulated rig before capture stored scene models: writes the
// scene model of the rig and world the session keeps in <session>/rig/ as a new scene_model row,
// lamps tracked over the session's frames (+- 1 min) and the rig's capture window. Returns the
// row's id. Throws InvalidArgumentError when the session keeps no simulated rig or already has a
// scene model (naming its row), IoError when it cannot be written (e.g. another process is
// writing the session).
std::int64_t AddSceneModelFromStoredRig(const std::filesystem::path& session_dir);

}  // namespace relume::rig
