#include "processing/radiosity/relight.h"

#include <cmath>
#include <limits>
#include <numbers>

#include "core/error.h"

namespace relume::radiosity {

bool RoomRelightOptions::IsValid(std::string* why) const {
  std::string reason;
  if (!direct.IsValid(&reason)) {
    if (why) *why = "direct: " + reason;
    return false;
  }
  if (!radiosity.IsValid(&reason)) {
    if (why) *why = "radiosity: " + reason;
    return false;
  }
  return true;
}

namespace {

void CheckPixels(const PatchHierarchy& hierarchy, const std::vector<Rgb>& albedo, const PixelPatches& pixels) {
  if (static_cast<int>(albedo.size()) != hierarchy.LeafCount()) {
    throw InvalidArgumentError("RelightRoom: " + std::to_string(albedo.size()) + " albedo values for " +
                               std::to_string(hierarchy.LeafCount()) + " patches");
  }
  if (pixels.patch_ids.type() != CV_32SC1 || pixels.points_m.type() != CV_32FC3 ||
      pixels.patch_ids.size() != pixels.points_m.size()) {
    throw InvalidArgumentError(
        "RelightRoom: the pixel maps must be patch ids (CV_32SC1) and points (CV_32FC3) of "
        "one size");
  }
}

}  // namespace

RadianceImage RelitPixels(const PatchHierarchy& hierarchy, const RayCaster& caster, const std::vector<Rgb>& albedo,
                          const Lighting& lighting, const std::vector<Rgb>& indirect_irradiance,
                          const PixelPatches& pixels, const DirectLightOptions& direct) {
  CheckPixels(hierarchy, albedo, pixels);
  if (indirect_irradiance.size() != albedo.size()) {
    throw InvalidArgumentError("RelitPixels: the indirect irradiance is not one per patch");
  }
  const cv::Mat& ids = pixels.patch_ids;
  RadianceImage relit = MakeRadianceImage(ids.cols, ids.rows, RadianceUnit::kWattsPerSqmPerSr);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < ids.rows; ++y) {
    const auto* id = ids.ptr<int>(y);
    const auto* xyz = pixels.points_m.ptr<cv::Vec3f>(y);
    auto* out = relit.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < ids.cols; ++x) {
      const int p = id[x];
      if (p < 0 || p >= hierarchy.LeafCount() || !std::isfinite(xyz[x][0] + xyz[x][1] + xyz[x][2])) {
        out[x] = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const Rgb e = DirectIrradianceAtPoint(caster, lighting, Eigen::Vector3d(xyz[x][0], xyz[x][1], xyz[x][2]),
                                            hierarchy.leaf(p).normal, direct);
      const Rgb v = albedo[p].cwiseProduct(e + indirect_irradiance[p]) / std::numbers::pi;
      out[x] = cv::Vec3f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    }
  }
  return relit;
}

RoomRelightResult RelightRoom(const PatchHierarchy& hierarchy, const RayCaster& caster, const std::vector<Rgb>& albedo,
                              const Lighting& lighting, const PixelPatches& pixels, const RoomRelightOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgumentError("RelightRoom options: " + why);
  CheckPixels(hierarchy, albedo, pixels);
  const DirectLight direct = ComputeDirectLight(hierarchy, caster, lighting, options.direct);
  RadiositySolver solver(hierarchy, caster, options.radiosity);
  RadiositySolution solution;
  RoomRelightResult result;
  result.solution = solver.Solve(albedo, direct.irradiance, hierarchy.LeafEmission(), &solution);
  result.relit = RelitPixels(hierarchy, caster, albedo, lighting, solution.indirect_irradiance, pixels, options.direct);
  result.radiosity = std::move(solution.radiosity);
  return result;
}

}  // namespace relume::radiosity
