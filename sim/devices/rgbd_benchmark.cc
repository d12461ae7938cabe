// RGB-D sensor throughput at 640x480: frames per second delivered by SimRgbdSensor
// (items_per_second) rendering the analytic wall-and-sphere scene, free-running on a manual
// clock, and its parts (truth render, depth model, registration) for scale.
// Run: build/sim/devices/rgbd_benchmark
#include <benchmark/benchmark.h>

#include "sim/devices/sim_rgbd_sensor.h"
#include "sim/devices/test_rig.h"

namespace relume::sim {
namespace {

using testing::LookingAtWall;
using testing::TestRig;

drivers::RgbdStreamConfig Vga(bool registered) {
  drivers::RgbdStreamConfig config;
  config.register_depth_to_color = registered;
  return config;
}

// arg 0: registration off/on.
void BM_SimRgbdSensorFrames(benchmark::State& state) {
  TestRig rig;
  SimRgbdOptions options;
  options.queue_full = SimRgbdOptions::QueueFull::kWait;  // lossless: every frame is counted
  drivers::DeviceInfo info;
  info.backend = "sim";
  info.id = "kinect0";
  SimRgbdSensor sensor(info, options, LookingAtWall(640, 480, 58.5), rig.truth, rig.clock);
  sensor.Start(Vga(state.range(0) == 1));
  for (auto _ : state) benchmark::DoNotOptimize(sensor.WaitForFrame(std::chrono::seconds(60)));
  sensor.Stop();
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(std::string("640x480, registration ") + (state.range(0) ? "on" : "off") +
                 ", frames/s = items_per_second");
}
BENCHMARK(BM_SimRgbdSensorFrames)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_AnalyticTruthRender(benchmark::State& state) {
  TestRig rig;
  const PinholeCamera camera = LookingAtWall(640, 480, 58.5);
  for (auto _ : state) benchmark::DoNotOptimize(rig.truth->Render(camera, testing::RigStart()));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_AnalyticTruthRender)->Unit(benchmark::kMillisecond);

void BM_MeasureDepth(benchmark::State& state) {
  TestRig rig;
  const PinholeCamera camera = LookingAtWall(640, 480, 58.5);
  const GroundTruth truth = rig.truth->Render(camera, testing::RigStart());
  std::uint64_t seed = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(MeasureDepth(truth.depth_m, truth.normal_in_world, camera, DepthModelOptions{}, ++seed));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MeasureDepth)->Unit(benchmark::kMillisecond);

void BM_RegisterDepthToColor(benchmark::State& state) {
  TestRig rig;
  const PinholeCamera camera = LookingAtWall(640, 480, 58.5);
  const GroundTruth truth = rig.truth->Render(camera, testing::RigStart());
  const cv::Mat depth = MeasureDepth(truth.depth_m, truth.normal_in_world, camera, DepthModelOptions{}, 1);
  const Eigen::Isometry3d color_from_depth(Eigen::Translation3d(-0.025, 0, 0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(RegisterDepthToColor(depth, camera.intrinsics, camera.intrinsics, color_from_depth));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RegisterDepthToColor)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace relume::sim

BENCHMARK_MAIN();
