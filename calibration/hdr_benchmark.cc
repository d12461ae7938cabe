// Run time and error of response recovery and HDR merge, relume against OpenCV's photo
// module (CalibrateDebevec, CalibrateRobertson, MergeDebevec), on synthetic brackets with a
// known radiance (calibration/testing/synthetic_bracket.h).
//
// Counters: curve_err = largest relative error of the inverse response over codes 24..235;
// prior_dis / low_conf: the response summary's prior disagreement and low-confidence flag;
// rad_err = mean relative radiance error where some frame is well exposed (codes 10..245),
// after one scale per channel; MP/s = megapixels merged per second.
#include <benchmark/benchmark.h>

#include <map>
#include <opencv2/photo.hpp>
#include <tuple>

#include "calibration/hdr_merge.h"
#include "calibration/response.h"
#include "calibration/testing/synthetic_bracket.h"

namespace relume::calibration {
namespace {

using testing::ResponseShape;
using testing::SyntheticResponse;

struct Case {
  cv::Mat radiance;
  std::vector<double> times;
  std::vector<CameraImage> frames;
  std::vector<cv::Mat> mats;
  std::vector<float> times_f;
  cv::Mat mask;
};

// Brackets are built once per (size, frames, shape, noise, spacing) and cached. `unequal`:
// steps alternating 1.2 and 0.8 times their mean, as relume's bracket planner spaces them.
const Case& GetCase(int width, int height, int frames, ResponseShape shape, bool noisy, bool unequal = false) {
  static std::map<std::tuple<int, int, int, int, bool, bool>, Case> cache;
  const auto key = std::make_tuple(width, height, frames, static_cast<int>(shape), noisy, unequal);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  Case c;
  testing::SceneOptions scene;
  scene.width = width;
  scene.height = height;
  scene.dynamic_range = 1e4;
  c.radiance = testing::MakeHdrRadiance(scene);
  // The bracket spans the same 8 stops whatever the frame count.
  c.times = unequal ? testing::UnequalBracketExposures(frames, 8.0 / (frames - 1), 18.0, 0.2)
                    : testing::BracketExposures(frames, 8.0 / (frames - 1), 18.0);
  testing::NoiseOptions noise;
  if (noisy) {
    noise.shot_noise = 2e-5;
    noise.read_noise = 2e-4;
  }
  c.frames = testing::RenderBracket(c.radiance, c.times, SyntheticResponse{shape}, noise);
  for (const auto& f : c.frames) c.mats.push_back(f.pixels);
  for (double t : c.times) c.times_f.push_back(static_cast<float>(t));
  c.mask = testing::WellExposedMask(c.radiance, c.times, SyntheticResponse{shape});
  return cache.emplace(key, std::move(c)).first->second;
}

double CurveError(const CameraResponse& r, ResponseShape shape) {
  const CameraResponse truth = testing::TrueInverseResponse(SyntheticResponse{shape});
  double worst = 0.0;
  for (int c = 0; c < 3; ++c) {
    for (int z = 24; z <= 235; ++z) worst = std::max(worst, std::abs(r.inverse[c][z] / truth.inverse[c][z] - 1.0));
  }
  return worst;
}

CameraResponse FromOpenCv(const cv::Mat& response) {
  CameraResponse r;
  r.levels = 256;
  r.inverse.assign(3, std::vector<double>(256));
  for (int c = 0; c < 3; ++c) {
    const double mid = response.at<cv::Vec3f>(128)[c];
    for (int z = 0; z < 256; ++z) r.inverse[c][z] = response.at<cv::Vec3f>(z)[c] / mid;
  }
  return r;
}

ResponseShape ShapeArg(const benchmark::State& state) {
  return static_cast<ResponseShape>(state.range(1));
}

void SetLabel(benchmark::State& state) {
  state.SetLabel(std::string(testing::ToString(ShapeArg(state))) + (state.range(2) ? " noisy" : " clean") +
                 (state.range(3) ? ", unequal steps" : ""));
}

// Response recovery + merge, end to end, on 640 x 480. prior_dis = the summary's prior
// disagreement (the two smoothness terms' curves apart), low_conf = 1 when flagged.
void RunRelumeDebevec(benchmark::State& state, const ResponseOptions& options) {
  const Case& c = GetCase(640, 480, static_cast<int>(state.range(0)), ShapeArg(state), state.range(2), state.range(3));
  ResponseResult r;
  for (auto _ : state) {
    r = RecoverResponse(c.frames, c.times, options);
    benchmark::DoNotOptimize(r);
  }
  const HdrMergeResult m = MergeHdr(c.frames, c.times, r.response);
  state.counters["curve_err"] = CurveError(r.response, ShapeArg(state));
  state.counters["rad_err"] = testing::CompareRadiance(m.radiance.pixels, c.radiance, c.mask).mean_relative;
  state.counters["prior_dis"] = r.summary.prior_disagreement.value_or(0.0);
  state.counters["low_conf"] = r.summary.low_confidence ? 1.0 : 0.0;
  SetLabel(state);
}

// The defaults (log-code smoothness, lambda 60), and Debevec's term as it was before (code, 40).
void BM_RelumeDebevec(benchmark::State& state) {
  RunRelumeDebevec(state, ResponseOptions{});
}
void BM_RelumeDebevecCode(benchmark::State& state) {
  ResponseOptions options;
  options.smoothness = ResponseSmoothness::kCode;
  options.lambda = 40.0;
  RunRelumeDebevec(state, options);
}

void BM_RelumeRobertson(benchmark::State& state) {
  const Case& c = GetCase(640, 480, static_cast<int>(state.range(0)), ShapeArg(state), state.range(2), state.range(3));
  ResponseOptions options;
  options.method = ResponseMethod::kRobertson;
  ResponseResult r;
  for (auto _ : state) {
    r = RecoverResponse(c.frames, c.times, options);
    benchmark::DoNotOptimize(r);
  }
  const HdrMergeResult m = MergeHdr(c.frames, c.times, r.response);
  state.counters["curve_err"] = CurveError(r.response, ShapeArg(state));
  state.counters["rad_err"] = testing::CompareRadiance(m.radiance.pixels, c.radiance, c.mask).mean_relative;
  state.counters["iterations"] = r.summary.iterations;
  SetLabel(state);
}

void BM_OpenCvDebevec(benchmark::State& state) {
  const Case& c = GetCase(640, 480, static_cast<int>(state.range(0)), ShapeArg(state), state.range(2), state.range(3));
  cv::Mat response;
  auto calibrate = cv::createCalibrateDebevec();
  for (auto _ : state) {
    calibrate->process(c.mats, response, c.times_f);
    benchmark::DoNotOptimize(response);
  }
  cv::Mat merged;
  cv::createMergeDebevec()->process(c.mats, merged, c.times_f, response);
  state.counters["curve_err"] = CurveError(FromOpenCv(response), ShapeArg(state));
  state.counters["rad_err"] = testing::CompareRadiance(merged, c.radiance, c.mask).mean_relative;
  SetLabel(state);
}

void BM_OpenCvRobertson(benchmark::State& state) {
  const Case& c = GetCase(640, 480, static_cast<int>(state.range(0)), ShapeArg(state), state.range(2), state.range(3));
  cv::Mat response;
  auto calibrate = cv::createCalibrateRobertson();
  for (auto _ : state) {
    calibrate->process(c.mats, response, c.times_f);
    benchmark::DoNotOptimize(response);
  }
  cv::Mat merged;
  cv::createMergeDebevec()->process(c.mats, merged, c.times_f, response);
  state.counters["curve_err"] = CurveError(FromOpenCv(response), ShapeArg(state));
  state.counters["rad_err"] = testing::CompareRadiance(merged, c.radiance, c.mask).mean_relative;
  SetLabel(state);
}

// {frames, shape, noisy, unequal steps}: the brackets span 8 stops.
void CalibrationArgs(benchmark::internal::Benchmark* b) {
  for (int frames : {3, 5, 9}) {
    for (int shape : {0, 1, 2}) b->Args({frames, shape, 1, 0});
  }
  b->Args({5, 0, 0, 0});
  for (int frames : {3, 5}) {
    for (int shape : {0, 1, 2}) b->Args({frames, shape, 1, 1});
  }
  b->Unit(benchmark::kMillisecond);
}
// The standard encodings (sRGB, Rec. 709, sRGB + S tone, log), noisy: relume only, to check
// that what was chosen on the three shapes above holds for curves it was not chosen on.
void StandardEncodingArgs(benchmark::internal::Benchmark* b) {
  for (int frames : {3, 5, 9}) {
    for (int shape : {3, 4, 5, 6}) b->Args({frames, shape, 1, 0});
  }
  b->Unit(benchmark::kMillisecond);
}
BENCHMARK(BM_RelumeDebevec)->Apply(CalibrationArgs)->Apply(StandardEncodingArgs);
BENCHMARK(BM_RelumeDebevecCode)->Apply(CalibrationArgs)->Apply(StandardEncodingArgs);
BENCHMARK(BM_OpenCvDebevec)->Apply(CalibrationArgs);
BENCHMARK(BM_RelumeRobertson)->Apply(CalibrationArgs);
BENCHMARK(BM_OpenCvRobertson)->Apply(CalibrationArgs);

// Merge throughput: 5 (or n) exposures of 2048 x 1536 (3.1 MP), true response for both.
void BM_RelumeMerge(benchmark::State& state) {
  const Case& c = GetCase(2048, 1536, static_cast<int>(state.range(0)), ResponseShape::kGamma, true);
  const CameraResponse response = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma});
  HdrMergeOptions options;
  options.threads = static_cast<int>(state.range(1));
  HdrMergeResult m;
  for (auto _ : state) {
    m = MergeHdr(c.frames, c.times, response, options);
    benchmark::DoNotOptimize(m);
  }
  state.counters["MP/s"] = benchmark::Counter(c.radiance.total() * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["rad_err"] = testing::CompareRadiance(m.radiance.pixels, c.radiance, c.mask).mean_relative;
}
BENCHMARK(BM_RelumeMerge)
    ->Args({5, 1})
    ->Args({5, 2})
    ->Args({3, 2})
    ->Args({9, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_OpenCvMergeDebevec(benchmark::State& state) {
  const Case& c = GetCase(2048, 1536, static_cast<int>(state.range(0)), ResponseShape::kGamma, true);
  const CameraResponse truth = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma});
  cv::Mat response(256, 1, CV_32FC3);
  for (int z = 0; z < 256; ++z) {
    for (int ch = 0; ch < 3; ++ch)
      response.at<cv::Vec3f>(z)[ch] = static_cast<float>(std::max(truth.inverse[ch][z], 1e-6));
  }
  cv::Mat merged;
  auto merge = cv::createMergeDebevec();
  for (auto _ : state) {
    merge->process(c.mats, merged, c.times_f, response);
    benchmark::DoNotOptimize(merged);
  }
  state.counters["MP/s"] = benchmark::Counter(c.radiance.total() * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["rad_err"] = testing::CompareRadiance(merged, c.radiance, c.mask).mean_relative;
}
BENCHMARK(BM_OpenCvMergeDebevec)->Arg(5)->Arg(3)->Arg(9)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace relume::calibration

BENCHMARK_MAIN();
