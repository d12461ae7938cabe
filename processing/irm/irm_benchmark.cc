// IRM relighting speed: shadow-ray and camera-ray throughput, and the whole relighting of a
// photograph against its size, bin count and sun samples. Run: build/release/processing/irm_benchmark
#include <benchmark/benchmark.h>

#include "processing/irm/relight.h"
#include "processing/irm/testing_scene.h"

namespace relume::irm {
namespace {

struct Fixture {
  testing::OutdoorScene scene{16};
  RayCaster caster{scene.mesh};
  testing::Light source_light{testing::SunFromAzimuthElevationDeg(95, 25), {900, 850, 780}, {28, 33, 45}};
  testing::Light target_light{testing::SunFromAzimuthElevationDeg(230, 50), {1000, 980, 950}, {20, 26, 40}};
  PinholeCamera Camera(int width, int height) const {
    return PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(width, height, 1.1), {-14, -30, 10}, {2, 0, 5});
  }
};
Fixture& GetFixture() {
  static Fixture fixture;
  return fixture;
}

void BM_ShadowRays(benchmark::State& state) {
  Fixture& f = GetFixture();
  const TriangleMesh& mesh = f.scene.mesh;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t v = i++ % mesh.vertex_count();
    benchmark::DoNotOptimize(
        f.caster.Occluded(mesh.positions[v] + mesh.normals[v] * 0.01f, f.source_light.sun_dir, 0, INFINITY));
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("rays/s per core");
}
BENCHMARK(BM_ShadowRays);

// The sun-disk rays of one surface point (16 directions, SunVisibleFraction) in packets, as
// the exact shadow-edge pixels and the per-vertex fractions cast them.
void BM_SunDiskRays(benchmark::State& state) {
  Fixture& f = GetFixture();
  const TriangleMesh& mesh = f.scene.mesh;
  const std::vector<Eigen::Vector3f> disk = SunDiskDirections(f.source_light.sun_dir, 0.00465f, 16);
  std::vector<std::size_t> facing;  // every ray of these vertices is cast (none behind the surface)
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.normals[v].dot(f.source_light.sun_dir) > 0.05f) facing.push_back(v);
  }
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t v = facing[i++ % facing.size()];
    benchmark::DoNotOptimize(SunVisibleFraction(f.caster, mesh.positions[v], mesh.normals[v], disk));
  }
  state.SetItemsProcessed(state.iterations() * 16);
  state.SetLabel("rays/s per core");
}
BENCHMARK(BM_SunDiskRays);

void BM_CameraRays(benchmark::State& state) {
  Fixture& f = GetFixture();
  const PinholeCamera camera = f.Camera(4000, 3000);
  std::vector<RayCaster::Hit> hits(4000);
  int y = 0;
  for (auto _ : state) {
    f.caster.IntersectCameraRow(camera, y++ % 3000, 0, 4000, hits);
    benchmark::DoNotOptimize(hits.data());
  }
  state.SetItemsProcessed(state.iterations() * 4000);
  state.SetLabel("packet rays/s per core");
}
BENCHMARK(BM_CameraRays);

// Whole relighting; args: width (height = 3/4 width), bins, sun samples. Preprocessing
// (per-vertex rays) included. 2 threads.
void BM_Relight(benchmark::State& state) {
  Fixture& f = GetFixture();
  const int width = static_cast<int>(state.range(0));
  const int height = width * 3 / 4;
  const PinholeCamera camera = f.Camera(width, height);
  // Radiance content does not change the cost: flat images of the right size.
  RadianceImage source = MakeRadianceImage(width, height);
  source.pixels.setTo(cv::Scalar(1, 1, 1));
  RelightOptions options;
  options.irm.bins = static_cast<int>(state.range(1));
  options.sun_samples = static_cast<int>(state.range(2));
  RelightSummary last;
  for (auto _ : state) {
    const RelightResult result = RelightImage(f.caster, {&source, camera, f.source_light.sun_dir, {}},
                                              {&source, camera, f.target_light.sun_dir, {}}, options);
    last = result.summary;
  }
  state.counters["preprocess_s"] = last.preprocess_s;
  state.counters["build_s"] = last.build_s;
  state.counters["relight_s"] = last.relight_s;
  state.counters["MP"] = width * height / 1e6;
}
BENCHMARK(BM_Relight)
    ->Args({1000, 32, 16})
    ->Args({2000, 32, 16})
    ->Args({2000, 16, 16})
    ->Args({2000, 64, 16})
    ->Args({2000, 32, 4})
    ->Args({2000, 32, 64})
    ->Args({6000, 32, 16})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// The per-pixel stage alone (RelightPixels), the one the 24 MP-in-a-second goal is about: the
// per-vertex view geometry and the IRM build are separate cached stages of the pipeline and
// are prepared outside the timed loop. IRMs from a 200 x 150 pair of renders under the two suns
// (so the maps, the model and its correction are real); the relit photograph is args width x
// height from the source's pose and field of view. Args: width, height, bins, sun samples,
// threads.
// CPU time is the whole process's (both threads), real time the wall clock.
void BM_RelightPixels(benchmark::State& state) {
  Fixture& f = GetFixture();
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  RelightOptions options;
  options.irm.bins = static_cast<int>(state.range(2));
  options.sun_samples = static_cast<int>(state.range(3));
  options.threads = static_cast<int>(state.range(4));
  const PinholeCamera small_source = f.Camera(200, 150);
  const PinholeCamera small_target =
      PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(200, 150, 1.1), {10, -32, 12}, {0, 0, 4});
  const RadianceImage source_render = testing::Render(f.caster, small_source, f.source_light);
  const RadianceImage target_render = testing::Render(f.caster, small_target, f.target_light);
  const View small_s{&source_render, small_source, f.source_light.sun_dir, {}};
  const View small_t{&target_render, small_target, f.target_light.sun_dir, {}};
  RelightSummary summary;
  const IrmSet irms = BuildIrmsFromViews(f.caster, small_s, small_t, ComputeViewGeometry(f.caster, small_s, options),
                                         ComputeViewGeometry(f.caster, small_t, options, false), options, &summary);
  // Radiance content does not change the cost: a flat image of the right size.
  RadianceImage source = MakeRadianceImage(width, height);
  source.pixels.setTo(cv::Scalar(1, 1, 1));
  const PinholeCamera camera =
      PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(width, height, 1.1), {-14, -30, 10}, {2, 0, 5});
  const View s{&source, camera, f.source_light.sun_dir, {}};
  const View t{&source, camera, f.target_light.sun_dir, {}};
  const ViewGeometry gs = ComputeViewGeometry(f.caster, s, options);
  const ViewGeometry gt = ComputeViewGeometry(f.caster, t, options, false);
  RelightSummary last;
  for (auto _ : state) {
    const RelightResult result = RelightPixels(f.caster, s, t, gs, gt, irms, options, summary);
    last = result.summary;
  }
  const double pixels = static_cast<double>(width) * height;
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(pixels));
  state.counters["MP"] = pixels / 1e6;
  state.counters["view_s"] = gs.seconds + gt.seconds;  // the two view stages for this camera, once
  state.counters["relit_share"] = static_cast<double>(last.pixels_relit) / pixels;
  state.counters["own_sun_rays_share"] = static_cast<double>(last.pixels_with_own_sun_rays) / pixels;
  state.counters["own_sky_rays_share"] = static_cast<double>(last.pixels_with_own_sky_rays) / pixels;
  state.SetLabel(irms.single_map ? "one map" : "four maps");
}
// 24 MP (the goal), and 3 MP for scale.
BENCHMARK(BM_RelightPixels)
    ->Args({2000, 1500, 32, 16, 2})
    ->Args({6000, 4000, 32, 16, 2})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Iterations(3);
// The knobs (at 3 MP, to keep the smoke run short): bins change only the tables, sun samples
// the exact shadow-edge rays; one thread against two (load balance, sharing between workers).
BENCHMARK(BM_RelightPixels)
    ->Args({2000, 1500, 32, 16, 1})
    ->Args({2000, 1500, 16, 16, 2})
    ->Args({2000, 1500, 64, 16, 2})
    ->Args({2000, 1500, 32, 4, 2})
    ->Args({2000, 1500, 32, 64, 2})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
}  // namespace relume::irm

BENCHMARK_MAIN();
