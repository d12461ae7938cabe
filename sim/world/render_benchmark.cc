// Render time of the simulated world's ground truth against its quality knobs: sun-disk
// samples, sky samples, indirect bounces and resolution, on the shipped outdoor scene
// (config/scenes/outdoor-building.yaml, aerial camera) with one thread, so the numbers are
// per core.
#include <benchmark/benchmark.h>

#include "sim/world/scene_yaml.h"
#include "sim/world/world.h"

namespace relume::sim {
namespace {

// args: width, height, sun samples, sky samples, indirect bounces.
void BM_RenderOutdoor(benchmark::State& state) {
  Scene scene = LoadScene(RELUME_SCENES_DIR "/outdoor-building.yaml");
  RenderOptions options = scene.render;
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  options.sun_samples = static_cast<int>(state.range(2));
  options.sky_samples = static_cast<int>(state.range(3));
  options.indirect_bounces = static_cast<int>(state.range(4));
  options.indirect_samples = 4;
  if (options.sky_samples == 0) {
    scene.sky = Sky::Black();  // 0 = no sky rays at all
    options.sky_samples = 1;
  }
  options.threads = 1;
  const World world(scene, options);
  const PinholeCamera camera = world.Camera("aerial", width, height);
  for (auto _ : state) {
    GroundTruth truth = world.Render(camera, scene.time);
    benchmark::DoNotOptimize(truth.radiance.pixels.data);
  }
  state.counters["Mpixel/s"] = benchmark::Counter(
      static_cast<double>(width) * height * static_cast<double>(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderOutdoor)
    ->ArgNames({"w", "h", "sun", "sky", "bounces"})
    ->Args({320, 180, 1, 0, 0})
    ->Args({320, 180, 4, 0, 0})
    ->Args({320, 180, 16, 0, 0})
    ->Args({320, 180, 64, 0, 0})
    ->Args({320, 180, 4, 8, 0})
    ->Args({320, 180, 4, 32, 0})
    ->Args({320, 180, 4, 128, 0})
    ->Args({320, 180, 4, 32, 1})
    ->Args({640, 360, 4, 0, 0})
    ->Args({1920, 1080, 1, 0, 0})
    ->Args({1920, 1080, 4, 0, 0})
    ->Args({1920, 1080, 4, 8, 0})
    ->Unit(benchmark::kMillisecond);

void BM_BuildWorld(benchmark::State& state) {
  const Scene scene = LoadScene(RELUME_SCENES_DIR "/outdoor-building.yaml");
  for (auto _ : state) {
    const World world(scene);
    benchmark::DoNotOptimize(&world);
  }
}
BENCHMARK(BM_BuildWorld)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace relume::sim

BENCHMARK_MAIN();
