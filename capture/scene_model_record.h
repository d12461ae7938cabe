// A session's scene model (core/scene_model.h) as a calibration row of kind kSceneModelKind:
// JSON with a version, so a later relume reads what an earlier one wrote and refuses, with a
// clear message, what a newer one wrote. Capture stores one for simulated rigs from their world
// (rig/scene_model_from_rig.h); calibration and import store them for real rigs. The latest row
// applies: a new calibration of a camera's pose is a new row, and the old one stays as a record.
//
// Stored form (version 1): {"version": 1, "source", "site": {latitude_deg, longitude_deg,
// height_m}, "cameras": [{device_id, intrinsics: {width, height, fx, fy, cx, cy},
// world_from_camera (row-major 4x4), has_pose, distortion, source, reprojection_error_px}], "materials": [{name,
// albedo?}], "objects":
// [{name, kind, vertices (flat x y z ...), triangles (flat), face_material, sphere_center,
// sphere_radius_m, material}], "lamps": [{name, type, intensity_w_sr, direction,
// cone_half_angle_deg, falloff_deg, track: [{utc_ns, utc, position}]}]}.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/scene_model.h"

namespace relume::capture {

inline constexpr const char* kSceneModelKind = "scene_model";

std::string SceneModelToJson(const SceneModel& model);
// Throws IoError naming `what` (e.g. "calibration row 7") when the JSON is not a scene model or
// fails SceneModel::IsValid, ConfigError when a newer relume wrote it.
SceneModel SceneModelFromJson(const std::string& json, const std::string& what);

// Stores `model` (checked with IsValid) in the session as a new scene_model row, which then
// applies; returns the row's id. IoError when the session cannot be written (e.g. another
// process is writing it), InvalidArgumentError for an invalid model.
std::int64_t StoreSceneModel(const std::filesystem::path& session_dir, const SceneModel& model);

// Stores a new scene model row that is the session's latest model (or, when it has none, an
// empty one at the session's site) with `camera` added, or replacing the camera of the same
// device. Returns the row's id. Errors as StoreSceneModel's.
std::int64_t SetSceneModelCamera(const std::filesystem::path& session_dir, const SceneModelCamera& camera);

// The session's latest scene model, or nothing. IoError when its row is unreadable.
std::optional<SceneModel> LatestSceneModel(const std::filesystem::path& session_dir);

struct CalibrationRecord;  // capture/session.h
// The latest kSceneModelKind row (in row order), or null when the session has none.
const CalibrationRecord* LatestSceneModelRow(const std::vector<CalibrationRecord>& rows);
// The result points into `rows`: a temporary would leave it dangling, so it is refused at compile time.
const CalibrationRecord* LatestSceneModelRow(std::vector<CalibrationRecord>&& rows) = delete;

// One line per part ("3 cameras, 7 objects (1204 triangles), 9 materials (1 with known albedo),
// 2 lamps") for `relume session info` and messages.
std::string DescribeSceneModel(const SceneModel& model);

}  // namespace relume::capture
