// Camera model throughput in megapixels per second (MP/s = items_per_second / 1e6): the
// noise-free path (radiance -> electrons), the noise step, and the two outputs, at 1920x1080
// and 6000x4000. Run: build/sim/devices/camera_model_benchmark
#include <benchmark/benchmark.h>

#include <numbers>

#include "sim/devices/camera_model.h"

namespace relume::sim {
namespace {

struct Input {
  PinholeIntrinsics intrinsics;
  RadianceImage radiance;
  ExposureParams exposure;
  CameraModelOptions options;
};

// A radiance ramp across the whole unsaturated range, with cos^4 vignetting.
Input MakeInput(int width, int height) {
  Input input;
  input.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, 60.0 * std::numbers::pi / 180.0);
  input.options.vignetting.model = Vignetting::Model::kCos4;
  input.radiance = MakeRadianceImage(width, height, RadianceUnit::kWattsPerSqmPerSr);
  const double top = SaturationRadiance(input.intrinsics, width / 2.0, height / 2.0, input.exposure, input.options);
  for (int y = 0; y < height; ++y) {
    cv::Vec3f* row = input.radiance.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < width; ++x) {
      const float value = static_cast<float>(top * (x + 0.5) / width);
      row[x] = cv::Vec3f(value, 0.8f * value, 0.6f * value);
    }
  }
  return input;
}

void SetRate(benchmark::State& state, const Input& input) {
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(input.intrinsics.width) *
                          input.intrinsics.height);
  state.SetLabel(std::to_string(input.intrinsics.width) + "x" + std::to_string(input.intrinsics.height) +
                 ", MP/s = items_per_second / 1e6");
}

void BM_ExpectedElectrons(benchmark::State& state) {
  const Input input = MakeInput(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(ExpectedElectrons(input.radiance, input.intrinsics, input.exposure, input.options));
  }
  SetRate(state, input);
}

void BM_AddSensorNoise(benchmark::State& state) {
  const Input input = MakeInput(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const cv::Mat electrons = ExpectedElectrons(input.radiance, input.intrinsics, input.exposure, input.options);
  std::uint64_t seed = 0;
  for (auto _ : state) benchmark::DoNotOptimize(AddSensorNoise(electrons, input.options, ++seed));
  SetRate(state, input);
}

// The whole raw path: electrons, noise, 14-bit counts (RGB; arg 2 = 1 for a Bayer mosaic).
void BM_RawFrame(benchmark::State& state) {
  Input input = MakeInput(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  if (state.range(2) == 1) input.options.raw_layout = ColorLayout::kBayerRggb;
  std::uint64_t seed = 0;
  for (auto _ : state) {
    const cv::Mat electrons = ExpectedElectrons(input.radiance, input.intrinsics, input.exposure, input.options);
    benchmark::DoNotOptimize(
        RawFromElectrons(AddSensorNoise(electrons, input.options, ++seed), input.exposure, input.options));
  }
  SetRate(state, input);
}

// The whole encoded path: electrons, noise, filmic response, 8 bits.
void BM_EncodedFrame(benchmark::State& state) {
  Input input = MakeInput(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  input.options.response = ResponseCurve::Filmic(2.2, 1.6);
  std::uint64_t seed = 0;
  for (auto _ : state) {
    const cv::Mat electrons = ExpectedElectrons(input.radiance, input.intrinsics, input.exposure, input.options);
    benchmark::DoNotOptimize(
        EncodedFromElectrons(AddSensorNoise(electrons, input.options, ++seed), input.exposure, input.options));
  }
  SetRate(state, input);
}

// Output stages alone (no noise), to show where the time goes.
void BM_RawOutputOnly(benchmark::State& state) {
  const Input input = MakeInput(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const cv::Mat electrons = ExpectedElectrons(input.radiance, input.intrinsics, input.exposure, input.options);
  for (auto _ : state) benchmark::DoNotOptimize(RawFromElectrons(electrons, input.exposure, input.options));
  SetRate(state, input);
}
void BM_EncodedOutputOnly(benchmark::State& state) {
  Input input = MakeInput(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  input.options.response = ResponseCurve::Filmic(2.2, 1.6);
  const cv::Mat electrons = ExpectedElectrons(input.radiance, input.intrinsics, input.exposure, input.options);
  for (auto _ : state) benchmark::DoNotOptimize(EncodedFromElectrons(electrons, input.exposure, input.options));
  SetRate(state, input);
}

// Stages alone at 1920x1080 (add ->Args({6000, 4000}) to see them at 24 MP; the CTest smoke run
// executes every registered case once, so the large ones are kept to the whole-frame paths).
BENCHMARK(BM_ExpectedElectrons)->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AddSensorNoise)->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RawOutputOnly)->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EncodedOutputOnly)->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RawFrame)
    ->Args({1920, 1080, 0})
    ->Args({1920, 1080, 1})
    ->Args({6000, 4000, 0})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EncodedFrame)->Args({1920, 1080})->Args({6000, 4000})->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace relume::sim

BENCHMARK_MAIN();
