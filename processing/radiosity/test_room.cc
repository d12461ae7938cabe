#include "processing/radiosity/test_room.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "core/error.h"

namespace relume::radiosity::testing {

TestRoom MakeTestRoom(int lamp_count) {
  RELUME_CHECK(lamp_count >= 1 && lamp_count <= 8);
  TestRoom room;
  Mesh& m = room.mesh;
  room.floor = m.AddMaterial({"floor", Rgb(0.35, 0.30, 0.25), Rgb::Zero()});
  room.ceiling = m.AddMaterial({"ceiling", Rgb(0.90, 0.90, 0.88), Rgb::Zero()});
  room.walls = m.AddMaterial({"walls", Rgb(0.70, 0.62, 0.50), Rgb::Zero()});
  room.desk = m.AddMaterial({"desk", Rgb(0.45, 0.30, 0.20), Rgb::Zero()});
  m.AddRoom({0, 0, 0}, {4.0, 3.0, 2.6}, room.floor, room.ceiling, room.walls);
  m.AddBox({1.2, 0.8, 0.70}, {2.6, 1.6, 0.74}, room.desk);
  for (const auto& [x, y] : {std::pair{1.25, 0.85}, {2.51, 0.85}, {1.25, 1.51}, {2.51, 1.51}}) {
    m.AddBox({x, y, 0.0}, {x + 0.04, y + 0.04, 0.70}, room.desk, /*skip_bottom=*/true);
  }
  const Eigen::Vector3d lamps[8] = {{0.8, 0.7, 1.8}, {3.2, 0.6, 1.6}, {3.3, 2.3, 2.0}, {0.7, 2.4, 1.5},
                                    {2.0, 1.2, 2.2}, {1.9, 2.5, 1.2}, {3.0, 1.5, 0.9}, {1.0, 1.5, 2.3}};
  room.lamp_positions_m.assign(lamps, lamps + lamp_count);
  return room;
}

std::vector<RadianceObservation> RenderPhotographs(const TestRoom& room, const PatchHierarchy& hierarchy,
                                                   const RayCaster& caster, const RenderOptions& options) {
  RadiosityOptions strict = options.radiosity;
  strict.bf_epsilon = std::min(strict.bf_epsilon, 2e-4);
  strict.rays_per_form_factor = std::max(strict.rays_per_form_factor, 16);
  strict.residual_tolerance = std::min(strict.residual_tolerance, 1e-6);
  strict.max_iterations = std::max(strict.max_iterations, 2000);
  strict.refinement_passes = std::max(strict.refinement_passes, 3);
  RadiositySolver solver(hierarchy, caster, strict);
  const int n = hierarchy.LeafCount();
  std::vector<bool> seen(n, false);
  for (int p = 0; p < n; ++p) {
    const Node& node = hierarchy.leaf(p);
    seen[p] = node.normal.dot(room.camera_position_m - node.centroid) > 0.0 &&
              !caster.SegmentOccluded(node.centroid, node.normal, room.camera_position_m, Eigen::Vector3d::Zero());
  }
  std::vector<RadianceObservation> out;
  for (const Eigen::Vector3d& lamp : room.lamp_positions_m) {
    RadianceObservation obs;
    obs.lighting.point_lights.push_back({lamp, room.lamp_intensity_w_per_sr});
    obs.camera_position_m = room.camera_position_m;
    const DirectLight direct = ComputeDirectLight(hierarchy, caster, obs.lighting, options.direct);
    RadiositySolution solution;
    const RadiositySummary summary =
        solver.Solve(hierarchy.LeafAlbedo(), direct.irradiance, hierarchy.LeafEmission(), &solution);
    RELUME_CHECK_MSG(summary.converged, summary.BriefReport());
    obs.radiance.assign(n, Rgb::Constant(std::numeric_limits<double>::quiet_NaN()));
    for (int p = 0; p < n; ++p) {
      if (seen[p]) obs.radiance[p] = solution.radiosity[p] / std::numbers::pi;
    }
    out.push_back(std::move(obs));
  }
  return out;
}

void AddCameraNoise(double relative_sigma, std::uint64_t seed, std::vector<RadianceObservation>* observations) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (auto& obs : *observations) {
    for (auto& l : obs.radiance) {
      if (!l.allFinite()) continue;
      for (int c = 0; c < 3; ++c) l[c] = std::max(0.0, l[c] * (1.0 + relative_sigma * normal(rng)));
    }
  }
}

void ApplyImageScales(const std::vector<double>& scales, std::vector<RadianceObservation>* observations) {
  RELUME_CHECK(scales.size() == observations->size());
  for (size_t s = 0; s < scales.size(); ++s) {
    for (auto& l : (*observations)[s].radiance) l *= scales[s];
  }
}

std::vector<MaterialError> CompareAlbedo(const PatchHierarchy& hierarchy, const std::vector<Rgb>& albedo,
                                         const std::vector<bool>& estimated) {
  const auto& materials = hierarchy.mesh().materials;
  std::vector<MaterialError> out(materials.size());
  for (size_t m = 0; m < materials.size(); ++m) {
    MaterialError& e = out[m];
    e.material = static_cast<int>(m);
    std::vector<double> values[3];
    Rgb sum = Rgb::Zero(), sum2 = Rgb::Zero();
    for (int p = 0; p < hierarchy.LeafCount(); ++p) {
      if (!estimated[p] || hierarchy.leaf(p).material != static_cast<int>(m)) continue;
      const Rgb& a = albedo[p];
      e.mean_abs_error += (a - materials[m].albedo).cwiseAbs().mean();
      sum += a;
      sum2 += a.cwiseProduct(a);
      for (int c = 0; c < 3; ++c) values[c].push_back(a[c]);
      ++e.patches;
    }
    if (e.patches == 0) continue;
    e.mean_abs_error /= e.patches;
    const Rgb mean = sum / e.patches;
    const Rgb var = (sum2 / e.patches - mean.cwiseProduct(mean)).cwiseMax(0.0);
    e.spread = var.cwiseSqrt().mean();
    for (int c = 0; c < 3; ++c) {
      std::sort(values[c].begin(), values[c].end());
      const auto at = [&](double q) { return values[c][static_cast<size_t>(q * (values[c].size() - 1))]; };
      e.range += (at(0.95) - at(0.05)) / 3.0;
    }
  }
  return out;
}

}  // namespace relume::radiosity::testing
