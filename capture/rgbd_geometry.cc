#include "capture/rgbd_geometry.h"

#include <nlohmann/json.hpp>

#include "capture/session.h"
#include "core/error.h"

namespace relume::capture {

nlohmann::json IntrinsicsToJson(const PinholeIntrinsics& k) {
  return {{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}};
}

PinholeIntrinsics IntrinsicsFromJson(const nlohmann::json& j) {
  PinholeIntrinsics k;
  k.width = j.at("width").get<int>();
  k.height = j.at("height").get<int>();
  k.fx = j.at("fx").get<double>();
  k.fy = j.at("fy").get<double>();
  k.cx = j.at("cx").get<double>();
  k.cy = j.at("cy").get<double>();
  return k;
}

std::string RgbdGeometryToJson(const drivers::RgbdFrame& frame) {
  std::vector<double> matrix;
  const Eigen::Matrix4d m = frame.color_from_depth.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) matrix.push_back(m(r, c));
  }
  const nlohmann::json j = {{"depth_intrinsics", IntrinsicsToJson(frame.depth_intrinsics)},
                            {"color_intrinsics", IntrinsicsToJson(frame.color_intrinsics)},
                            {"registered_to_color", frame.registered_to_color},
                            {"color_from_depth", matrix}};
  return j.dump();
}

void ApplyRgbdGeometryJson(const std::string& json, drivers::RgbdFrame* frame) {
  try {
    const nlohmann::json j = nlohmann::json::parse(json);
    frame->depth_intrinsics = IntrinsicsFromJson(j.at("depth_intrinsics"));
    frame->color_intrinsics = IntrinsicsFromJson(j.at("color_intrinsics"));
    frame->registered_to_color = j.at("registered_to_color").get<bool>();
    const std::vector<double> matrix = j.at("color_from_depth").get<std::vector<double>>();
    if (matrix.size() != 16) throw IoError(kRgbdGeometryKind, "color_from_depth must hold 16 numbers");
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) m(r, c) = matrix[static_cast<std::size_t>(4 * r + c)];
    }
    frame->color_from_depth = Eigen::Isometry3d(m);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(kRgbdGeometryKind, std::string("not a valid RGB-D geometry record: ") + e.what());
  }
}

const CalibrationRecord* RgbdGeometryAt(const std::vector<CalibrationRecord>& rows, const std::string& device_id,
                                        std::int64_t frame_id) {
  const CalibrationRecord* at = nullptr;
  for (const CalibrationRecord& row : rows) {
    if (row.kind != kRgbdGeometryKind || row.device_id != device_id) continue;
    if (!row.source_frame_ids.empty() && row.source_frame_ids.front() > frame_id) break;
    at = &row;
  }
  return at;
}

}  // namespace relume::capture
