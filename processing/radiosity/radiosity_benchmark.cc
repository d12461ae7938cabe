// Run time against error for hierarchical radiosity on the test room (one lamp): patch count
// (patch edge), BF refinement threshold, rays per form factor, and residual tolerance (which
// sets the iteration count). Error: area-weighted mean |B - B_ref| / mean B against a
// reference solve of the same patches with strict settings (bf_epsilon 2e-3, 8 rays,
// residual 1e-6). Arguments: patch edge mm, bf_epsilon x 1e4, rays, residual tolerance x 1e4.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/radiosity_solver.h"
#include "processing/radiosity/test_room.h"

namespace relume::radiosity {
namespace {

struct Setup {
  testing::TestRoom room = testing::MakeTestRoom(1);
  std::unique_ptr<PatchHierarchy> hierarchy;
  std::unique_ptr<RayCaster> caster;
  DirectLight direct;
  std::vector<Rgb> reference;
};

const Setup& GetSetup(int edge_mm) {
  static std::map<int, std::unique_ptr<Setup>> cache;
  auto& entry = cache[edge_mm];
  if (entry) return *entry;
  entry = std::make_unique<Setup>();
  HierarchyOptions ho;
  ho.max_patch_edge_m = edge_mm / 1000.0;
  entry->hierarchy = std::make_unique<PatchHierarchy>(entry->room.mesh, ho);
  entry->caster = std::make_unique<RayCaster>(entry->room.mesh.geometry);
  Lighting lighting;
  lighting.point_lights.push_back({entry->room.lamp_positions_m[0], entry->room.lamp_intensity_w_per_sr});
  entry->direct = ComputeDirectLight(*entry->hierarchy, *entry->caster, lighting, {});
  RadiosityOptions strict;
  strict.bf_epsilon = 2e-3;
  strict.rays_per_form_factor = 8;
  strict.residual_tolerance = 1e-6;
  strict.max_iterations = 2000;
  RadiositySolver solver(*entry->hierarchy, *entry->caster, strict);
  RadiositySolution solution;
  solver.Solve(entry->hierarchy->LeafAlbedo(), entry->direct.irradiance, entry->hierarchy->LeafEmission(), &solution);
  entry->reference = solution.radiosity;
  return *entry;
}

void BM_HierarchicalRadiosity(benchmark::State& state) {
  const Setup& setup = GetSetup(static_cast<int>(state.range(0)));
  RadiosityOptions options;
  options.bf_epsilon = state.range(1) * 1e-4;
  options.rays_per_form_factor = static_cast<int>(state.range(2));
  options.residual_tolerance = state.range(3) * 1e-4;
  RadiositySummary summary;
  RadiositySolution solution;
  const auto albedo = setup.hierarchy->LeafAlbedo();
  const auto emission = setup.hierarchy->LeafEmission();
  for (auto _ : state) {
    RadiositySolver solver(*setup.hierarchy, *setup.caster, options);
    summary = solver.Solve(albedo, setup.direct.irradiance, emission, &solution);
    benchmark::DoNotOptimize(solution.radiosity.data());
  }
  double diff = 0.0, total = 0.0;
  for (int p = 0; p < setup.hierarchy->LeafCount(); ++p) {
    const double a = setup.hierarchy->leaf(p).area_m2;
    diff += a * (solution.radiosity[p] - setup.reference[p]).cwiseAbs().mean();
    total += a * setup.reference[p].mean();
  }
  state.counters["patches"] = setup.hierarchy->LeafCount();
  state.counters["links"] = static_cast<double>(summary.links);
  state.counters["iterations"] = summary.iterations;
  state.counters["residual"] = summary.residual;
  state.counters["error"] = diff / total;
  state.counters["refine_s"] = summary.refine_time_s;
  state.counters["solve_s"] = summary.solve_time_s;
  state.counters["converged"] = summary.converged ? 1 : 0;
}

// Patch count (about 10k patches at 250 mm in this room), BF threshold, rays per form factor
// and residual tolerance (iterations).
BENCHMARK(BM_HierarchicalRadiosity)
    ->ArgNames({"edge_mm", "bf_e4", "rays", "tol_e4"})
    ->Args({600, 100, 4, 100})
    ->Args({400, 100, 4, 100})
    ->Args({250, 100, 4, 100})
    ->Args({250, 50, 4, 100})
    ->Args({250, 200, 4, 100})
    ->Args({250, 100, 1, 100})
    ->Args({250, 100, 8, 100})
    ->Args({250, 100, 4, 1000})
    ->Args({250, 100, 4, 10})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace relume::radiosity

BENCHMARK_MAIN();
