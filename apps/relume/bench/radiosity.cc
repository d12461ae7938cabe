// `radiosity`: on the test room, (1) the hierarchical radiosity solve alone across patch size,
// BF refinement epsilon, rays per form factor and residual tolerance (iterations), error
// against a strict solve of the same patches; (2) Loscos reflectance with the radiosity
// solution's indirect light across patch size, BF epsilon, rays and reflectance iterations,
// error = mean albedo error against the room's true albedo (the residual in the notes).
#include "apps/relume/bench/radiosity.h"

#include <cmath>
#include <string>

#include "apps/relume/bench/bench.h"
#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/radiosity_solver.h"

namespace relume::app::bench {

namespace rs = radiosity;

RadiosityRoom::RadiosityRoom(int lamp_count, double patch_edge_m, double albedo_scale)
    : room(rs::testing::MakeTestRoom(lamp_count)) {
  for (rs::Material& m : room.mesh.materials) m.albedo *= albedo_scale;
  rs::HierarchyOptions options;
  options.max_patch_edge_m = patch_edge_m;
  hierarchy = std::make_unique<rs::PatchHierarchy>(room.mesh, options);
  caster = std::make_unique<RayCaster>(room.mesh.geometry);
  photos = rs::testing::RenderPhotographs(room, *hierarchy, *caster);
}

double MeanAlbedoError(const RadiosityRoom& r, const rs::ReflectanceResult& result) {
  double sum = 0.0;
  int patches = 0;
  for (const rs::testing::MaterialError& e :
       rs::testing::CompareAlbedo(*r.hierarchy, result.albedo, result.estimated)) {
    sum += e.mean_abs_error * e.patches;
    patches += e.patches;
  }
  return patches > 0 ? sum / patches : NAN;
}

namespace {

std::string EdgeText(double edge_m) {
  return std::to_string(static_cast<int>(std::lround(edge_m * 1000))) + " mm";
}

void BenchSolve(bool quick, std::vector<Row>& rows) {
  struct Knobs {
    double edge_m, bf_epsilon;
    int rays;
    double tolerance;
  };
  const std::vector<Knobs> settings =
      quick ? std::vector<Knobs>{{0.6, 1e-2, 4, 1e-2}, {0.6, 2e-2, 1, 1e-2}, {0.6, 5e-3, 4, 1e-3}}
            : std::vector<Knobs>{{0.6, 1e-2, 4, 1e-2}, {0.4, 1e-2, 4, 1e-2}, {0.25, 1e-2, 4, 1e-2},
                                 {0.4, 5e-3, 4, 1e-2}, {0.4, 2e-2, 4, 1e-2}, {0.4, 1e-2, 1, 1e-2},
                                 {0.4, 1e-2, 8, 1e-2}, {0.4, 1e-2, 4, 1e-1}, {0.4, 1e-2, 4, 1e-3}};
  const rs::testing::TestRoom room = rs::testing::MakeTestRoom(1);
  const RayCaster caster(room.mesh.geometry);
  double edge_m = -1.0;
  std::unique_ptr<rs::PatchHierarchy> hierarchy;
  rs::DirectLight direct;
  std::vector<rs::Rgb> reference;
  for (const Knobs& k : settings) {
    if (k.edge_m != edge_m) {  // a strict solve of the same patches is the reference
      edge_m = k.edge_m;
      rs::HierarchyOptions ho;
      ho.max_patch_edge_m = edge_m;
      hierarchy = std::make_unique<rs::PatchHierarchy>(room.mesh, ho);
      rs::Lighting lighting;
      lighting.point_lights.push_back({room.lamp_positions_m[0], room.lamp_intensity_w_per_sr});
      direct = rs::ComputeDirectLight(*hierarchy, caster, lighting, {});
      rs::RadiosityOptions strict;
      strict.bf_epsilon = 2e-3;
      strict.rays_per_form_factor = 8;
      strict.residual_tolerance = 1e-6;
      strict.max_iterations = 2000;
      rs::RadiositySolver solver(*hierarchy, caster, strict);
      rs::RadiositySolution solution;
      solver.Solve(hierarchy->LeafAlbedo(), direct.irradiance, hierarchy->LeafEmission(), &solution);
      reference = solution.radiosity;
    }
    rs::RadiosityOptions options;
    options.bf_epsilon = k.bf_epsilon;
    options.rays_per_form_factor = k.rays;
    options.residual_tolerance = k.tolerance;
    rs::RadiositySummary summary;
    rs::RadiositySolution solution;
    const double seconds = BestSeconds(quick ? 1 : 2, [&] {
      rs::RadiositySolver solver(*hierarchy, caster, options);
      summary = solver.Solve(hierarchy->LeafAlbedo(), direct.irradiance, hierarchy->LeafEmission(), &solution);
    });
    double diff = 0.0, total = 0.0;
    for (int p = 0; p < hierarchy->LeafCount(); ++p) {
      const double a = hierarchy->leaf(p).area_m2;
      diff += a * (solution.radiosity[p] - reference[p]).cwiseAbs().mean();
      total += a * reference[p].mean();
    }
    rows.push_back({"radiosity", "hierarchical radiosity solve",
                    "patch edge " + EdgeText(k.edge_m) + " (" + std::to_string(hierarchy->LeafCount()) +
                        " patches), BF epsilon " + Format(k.bf_epsilon) + ", " + std::to_string(k.rays) +
                        " rays per form factor, residual tolerance " + Format(k.tolerance),
                    seconds, hierarchy->LeafCount() / seconds, "patches/s", diff / total,
                    "mean |B - B_strict| / mean B",
                    std::to_string(summary.iterations) + " iterations, residual " + Format(summary.residual) + ", " +
                        std::to_string(summary.links) + " links"});
  }
}

void BenchReflectance(bool quick, std::vector<Row>& rows) {
  struct Knobs {
    double edge_m, bf_epsilon;
    int rays, iterations;
  };
  const std::vector<Knobs> settings = quick
                                          ? std::vector<Knobs>{{0.6, 2e-3, 4, 6}, {0.6, 2e-3, 4, 1}, {0.6, 1e-2, 1, 6}}
                                          : std::vector<Knobs>{{0.6, 2e-3, 4, 6}, {0.6, 2e-3, 4, 1}, {0.6, 2e-3, 4, 2},
                                                               {0.6, 2e-3, 4, 3}, {0.6, 1e-2, 4, 6}, {0.6, 2e-3, 1, 6},
                                                               {0.6, 2e-3, 8, 6}, {0.4, 2e-3, 4, 6}, {0.4, 1e-2, 1, 6}};
  const int lamps = quick ? 2 : 4;
  double edge_m = -1.0;
  std::unique_ptr<RadiosityRoom> room;
  for (const Knobs& k : settings) {
    if (k.edge_m != edge_m) {
      edge_m = k.edge_m;
      room = std::make_unique<RadiosityRoom>(lamps, edge_m);
    }
    rs::ReflectanceOptions options;
    options.max_iterations = k.iterations;
    options.radiosity.bf_epsilon = k.bf_epsilon;
    options.radiosity.rays_per_form_factor = k.rays;
    rs::ReflectanceResult result;
    const double seconds = BestSeconds(
        1, [&] { result = rs::EstimateReflectance(*room->hierarchy, *room->caster, room->photos, options); });
    double residual = 0.0, solve_s = 0.0;
    for (const rs::RadiositySummary& s : result.last_solves) {
      residual = std::max(residual, s.residual);
      solve_s += s.refine_time_s + s.solve_time_s;
    }
    const int solves = static_cast<int>(result.last_solves.size());
    rows.push_back({"radiosity", "Loscos reflectance + hierarchical radiosity",
                    std::to_string(lamps) + " lamp images, patch edge " + EdgeText(k.edge_m) + " (" +
                        std::to_string(room->hierarchy->LeafCount()) + " patches), BF epsilon " + Format(k.bf_epsilon) +
                        ", " + std::to_string(k.rays) + " rays, max " + std::to_string(k.iterations) + " iterations",
                    seconds, room->hierarchy->LeafCount() / seconds, "patches/s", MeanAlbedoError(*room, result),
                    "mean albedo error",
                    std::to_string(result.iterations) + " iterations" + (result.converged ? " (converged)" : "") +
                        ", last residual " + Format(residual) + ", last solve " +
                        Format(solves ? solve_s / solves : 0.0) + " s per image"});
  }
}

}  // namespace

void BenchRadiosity(bool quick, std::vector<Row>& rows) {
  BenchSolve(quick, rows);
  BenchReflectance(quick, rows);
}

}  // namespace relume::app::bench
