// Frames per second through the OpenNI2 backend and the real libOpenNI2, against the simulated
// RGB-D driver (30 fps device clock): measures the time per synced depth + colour pair as the
// backend delivers it (waiting, conversion to metres and RGB). ctest sets LD_LIBRARY_PATH.
#include <benchmark/benchmark.h>

#include "drivers/openni2/openni2_backend.h"

namespace relume::drivers::openni2 {
namespace {

void BM_SimRgbdFrame(benchmark::State& state) {
  OpenNI2Backend backend;
  if (backend.Enumerate().empty()) {
    state.SkipWithError("no simulated sensor: put the build's openni2-runtime folder first on LD_LIBRARY_PATH");
    return;
  }
  const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open("relume-sim://rgbd/0");
  RgbdStreamConfig config;
  config.depth_width = config.color_width = static_cast<int>(state.range(0));
  config.depth_height = config.color_height = static_cast<int>(state.range(0)) * 3 / 4;
  config.fps = 30.0;
  config.register_depth_to_color = true;
  config.sync_depth_and_color = true;
  sensor->Start(config);
  sensor->WaitForFrame(std::chrono::seconds(5));
  for (auto _ : state) benchmark::DoNotOptimize(sensor->WaitForFrame(std::chrono::seconds(5)));
  sensor->Stop();
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimRgbdFrame)->Arg(640)->Arg(320)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace relume::drivers::openni2

BENCHMARK_MAIN();
