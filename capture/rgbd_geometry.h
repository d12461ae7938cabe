// The geometry of an RGB-D stream (both cameras' intrinsics, whether depth was registered to
// colour, the colour-from-depth transform) as JSON. SessionWriter stores it as a calibration
// row of kind kRgbdGeometryKind when a device's first frame arrives and whenever it changes,
// so a session holds what the player (capture/playback.h) and processing need to use its
// depth frames. Transform as a row-major 4x4 matrix, metres.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "drivers/frame.h"

namespace relume::capture {

inline constexpr const char* kRgbdGeometryKind = "rgbd_geometry";

// Intrinsics as {width, height, fx, fy, cx, cy}, the form every session row uses.
nlohmann::json IntrinsicsToJson(const PinholeIntrinsics& intrinsics);
// Throws nlohmann::json::exception for a missing or mistyped field (callers name the row).
PinholeIntrinsics IntrinsicsFromJson(const nlohmann::json& j);

std::string RgbdGeometryToJson(const drivers::RgbdFrame& frame);
// Sets depth_intrinsics, color_intrinsics, registered_to_color and color_from_depth of
// `frame`. Throws IoError when the JSON is not such a record.
void ApplyRgbdGeometryJson(const std::string& json, drivers::RgbdFrame* frame);

struct CalibrationRecord;  // capture/session.h
// The geometry row that applies to frame `frame_id` of `device_id`: the latest of that device's
// kRgbdGeometryKind rows (in row order) whose first source frame is at or before it. nullptr
// when none is. Used by playback and by processing, so both read a session the same way.
const CalibrationRecord* RgbdGeometryAt(const std::vector<CalibrationRecord>& rows, const std::string& device_id,
                                        std::int64_t frame_id);
// The result points into `rows`: a temporary would leave it dangling, so it is refused at compile time.
const CalibrationRecord* RgbdGeometryAt(std::vector<CalibrationRecord>&& rows, const std::string& device_id,
                                        std::int64_t frame_id) = delete;

}  // namespace relume::capture
