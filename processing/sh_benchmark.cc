// Speed of the SH relighting chain at 640 x 480 (one core), next to its error against the
// analytic truth, for the quality knobs: sample count, SH order, bilateral radius, normal
// window. Run: build/processing/sh_benchmark. Errors are relative RMS (see
// docs/processing-sh.md); inputs carry Kinect-like depth noise unless the name says ideal.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>

#include "processing/nonneg_light.h"
#include "processing/relight.h"
#include "processing/sh_pipeline.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

struct Fixture {
  testing::SceneOptions scene;
  testing::SyntheticFrame src, dst;
  cv::Mat noisy_depth_m;
  ShRgb src_light, dst_light;

  Fixture() {
    scene.intrinsics = PinholeIntrinsics::FromHorizontalFov(640, 480, 60.0 * std::numbers::pi / 180.0);
    testing::SkySunOptions a, b;
    a.sun_dir_in_map = Eigen::Vector3d(0.6, -0.4, 0.7).normalized();
    b.sun_dir_in_map = Eigen::Vector3d(-0.8, 0.3, 0.35).normalized();
    src_light = ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, a), testing::CameraFromMap());
    dst_light = ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, b), testing::CameraFromMap());
    src = testing::RenderScene(scene, src_light);
    dst = testing::RenderScene(scene, dst_light);
    noisy_depth_m = testing::AddKinectDepthNoise(src.depth_m, 42);
  }
};

const Fixture& Data() {
  static const Fixture fixture;
  return fixture;
}

double RelitError(const ShRgb& light, const NormalMap& normals, const RelightOptions& options = {}) {
  const Fixture& f = Data();
  const RelightResult r =
      RelightSh(f.src.radiance, normals.normal_in_camera, f.src.object_mask, light, f.dst_light, options);
  double error = 0.0, total = 0.0;
  for (int y = 0; y < r.valid.rows; ++y) {
    for (int x = 0; x < r.valid.cols; ++x) {
      if (!r.valid.at<unsigned char>(y, x)) continue;
      const cv::Vec3f t = f.dst.radiance.pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f d = r.relit.pixels.at<cv::Vec3f>(y, x) - t;
      error += d.dot(d);
      total += t.dot(t);
    }
  }
  return std::sqrt(error / total);
}

// The whole chain per frame: bilateral + temporal filter, normals, sample update, known-albedo
// fit, relight. Args: samples, bilateral radius, normal window radius, max SH order.
void BM_Chain(benchmark::State& state) {
  const Fixture& f = Data();
  ShEstimatorOptions options;
  options.samples.count = static_cast<int>(state.range(0));
  options.geometry.bilateral.radius_px = static_cast<int>(state.range(1));
  options.geometry.normals.window_radius_px = static_cast<int>(state.range(2));
  options.fit.fit.max_order = static_cast<int>(state.range(3));
  ShLightEstimator estimator(options);
  ShFrameEstimate estimate;
  RelightOptions relight;
  for (auto _ : state) {
    estimate = estimator.EstimateKnownAlbedo(f.src.radiance, f.noisy_depth_m, f.scene.intrinsics, f.src.object_mask,
                                             f.src.albedo);
    relight.normals_from_noisy_depth = estimate.depth_filtered;  // as the sh pipeline sets it
    const RelightResult r = RelightSh(f.src.radiance, estimate.normals.normal_in_camera, f.src.object_mask,
                                      estimate.light, f.dst_light, relight);
    benchmark::DoNotOptimize(r.relit.pixels.data);
  }
  state.counters["relit_err"] = RelitError(estimate.light, estimate.normals, relight);
  state.counters["order"] = estimate.summary.order_used;
}
BENCHMARK(BM_Chain)
    ->ArgNames({"samples", "filter_r", "normal_r", "order"})
    ->Args({2000, 2, 6, 2})
    ->Args({500, 2, 6, 2})
    ->Args({8000, 2, 6, 2})
    ->Args({2000, 1, 6, 2})
    ->Args({2000, 3, 6, 2})
    ->Args({2000, 2, 3, 2})
    ->Args({2000, 2, 10, 2})
    ->Args({2000, 2, 6, 1})
    ->Args({2000, 1, 3, 2})
    ->Args({2000, 1, 4, 2})
    ->Args({2000, 0, 4, 2})
    ->Unit(benchmark::kMillisecond);

void BM_BilateralFilter(benchmark::State& state) {
  BilateralDepthOptions options;
  options.radius_px = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(BilateralFilterDepth(Data().noisy_depth_m, options).data);
}
BENCHMARK(BM_BilateralFilter)->ArgName("radius")->Arg(1)->Arg(2)->Arg(3)->Arg(5)->Unit(benchmark::kMillisecond);

// Args: window radius; depth (0 filtered Kinect-like noise, said noisy as the SH geometry step
// says it, so no crease refinement; 1 exact, creases not refined; 2 exact, refined); fallback
// beside discontinuities (0 straight to one-pixel differences, the estimate before 2026-12-07;
// 1 the defaults: smaller boxes, on noisy depth the neighbours' boxes, on exact depth jets).
void BM_Normals(benchmark::State& state) {
  const Fixture& f = Data();
  NormalOptions options;
  options.window_radius_px = static_cast<int>(state.range(0));
  options.refine_creases = state.range(1) == 2;
  options.depth_noisy = state.range(1) == 0;
  if (state.range(2) == 0) {
    options.min_window_radius_px = std::max(1, options.window_radius_px);
    options.neighbour_boxes_on_noisy_depth = false;
    options.jet_radius_px = 0;
  }
  const cv::Mat depth = state.range(1) == 0 ? BilateralFilterDepth(f.noisy_depth_m) : f.src.depth_m;
  NormalMap normals;
  for (auto _ : state) normals = EstimateNormals(depth, f.scene.intrinsics, options);
  // Median angular error over the objects, beside the speed.
  std::vector<double> errors;
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      if (!f.src.object_mask.at<unsigned char>(y, x) || !normals.valid.at<unsigned char>(y, x)) continue;
      const double c = normals.normal_in_camera.at<cv::Vec3f>(y, x).dot(f.src.normal_in_camera.at<cv::Vec3f>(y, x));
      errors.push_back(std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi);
    }
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  state.counters["median_err_deg"] = errors[errors.size() / 2];
}
BENCHMARK(BM_Normals)
    ->ArgNames({"window", "depth", "fallback"})
    ->Args({0, 0, 1})
    ->Args({3, 0, 0})
    ->Args({3, 0, 1})
    ->Args({6, 0, 1})
    ->Args({10, 0, 1})
    ->Args({3, 1, 0})
    ->Args({3, 1, 1})
    ->Args({3, 2, 1})
    ->Unit(benchmark::kMillisecond);

struct Prepared {
  NormalMap normals;
  std::vector<cv::Point> object_points;
};
const Prepared& PreparedData() {
  static const Prepared prepared = [] {
    Prepared p;
    p.normals = EstimateNormals(BilateralFilterDepth(Data().noisy_depth_m), Data().scene.intrinsics);
    cv::findNonZero(Data().src.object_mask & p.normals.valid, p.object_points);
    return p;
  }();
  return prepared;
}

// The fit alone (gathering observations included). Args: samples (0 = every object pixel), order.
void BM_FitKnownAlbedo(benchmark::State& state) {
  const Fixture& f = Data();
  const Prepared& p = PreparedData();
  SamplePointSelector selector({.count = state.range(0) > 0 ? static_cast<int>(state.range(0)) : 1 << 30, .seed = 3});
  const std::vector<cv::Point> points = selector.Update(f.src.object_mask & p.normals.valid);
  ShFitOptions options;
  options.max_order = static_cast<int>(state.range(1));
  ShFitResult fit;
  for (auto _ : state) {
    fit = FitShKnownAlbedo(GatherObservations(f.src.radiance, p.normals.normal_in_camera, f.src.albedo, {}, points),
                           options);
  }
  state.counters["observations"] = fit.summary.observation_count;
  state.counters["relit_err"] = RelitError(fit.light, p.normals);
}
BENCHMARK(BM_FitKnownAlbedo)
    ->ArgNames({"samples", "order"})
    ->Args({500, 2})
    ->Args({2000, 2})
    ->Args({8000, 2})
    ->Args({0, 2})
    ->Args({2000, 1})
    ->Unit(benchmark::kMillisecond);

// Unknown albedo: k-means segmentation + sample update + alternating fit. Arg: samples.
void BM_FitUnknownAlbedo(benchmark::State& state) {
  const Fixture& f = Data();
  const Prepared& p = PreparedData();
  SegmentationOptions segmentation;
  segmentation.segment_count = 3;
  SamplePointSelector selector({.count = static_cast<int>(state.range(0)), .seed = 3});
  ShAlbedoFitResult fit;
  for (auto _ : state) {
    const Segmentation s =
        SegmentByColor(f.src.radiance, f.src.object_mask & p.normals.valid, p.normals.normal_in_camera, segmentation);
    const std::vector<cv::Point>& points = selector.Update(s.labels >= 0);
    ShAlbedoFitOptions options;
    options.reference_albedo = f.scene.big_sphere_albedo;
    fit = FitShUnknownAlbedo(GatherObservations(f.src.radiance, p.normals.normal_in_camera, {}, s.labels, points),
                             options);
  }
  state.counters["iterations"] = fit.summary.iterations;
  state.counters["relit_err"] = RelitError(fit.light, p.normals);
}
BENCHMARK(BM_FitUnknownAlbedo)->ArgName("samples")->Arg(500)->Arg(2000)->Arg(8000)->Unit(benchmark::kMillisecond);

// Arg: RelightOptions::ratio_radius_px (0: each pixel by its own ratio; 3: the default filter;
// 6: the default for normals from noisy depth, with its sigmas).
void BM_Relight(benchmark::State& state) {
  const Fixture& f = Data();
  const Prepared& p = PreparedData();
  RelightOptions options;
  options.ratio_radius_px = static_cast<int>(state.range(0));
  if (options.ratio_radius_px == options.noisy_ratio_radius_px) options.normals_from_noisy_depth = true;
  for (auto _ : state) {
    const RelightResult r =
        RelightSh(f.src.radiance, p.normals.normal_in_camera, f.src.object_mask, f.src_light, f.dst_light, options);
    benchmark::DoNotOptimize(r.relit.pixels.data);
  }
}
BENCHMARK(BM_Relight)->ArgName("ratio_radius")->Arg(0)->Arg(3)->Arg(6)->Unit(benchmark::kMillisecond);

// The non-negative directional light's fit (nonneg_light.h; one outlier refit, gathering
// included). Args: samples, directions.
void BM_FitNonNegative(benchmark::State& state) {
  const Fixture& f = Data();
  const Prepared& p = PreparedData();
  SamplePointSelector selector({.count = static_cast<int>(state.range(0)), .seed = 3});
  const std::vector<cv::Point> points = selector.Update(f.src.object_mask & p.normals.valid);
  NonNegativeLightOptions options;
  options.direction_count = static_cast<int>(state.range(1));
  NonNegativeLightResult fit;
  for (auto _ : state) {
    fit = FitNonNegativeLight(GatherObservations(f.src.radiance, p.normals.normal_in_camera, f.src.albedo, {}, points),
                              options);
  }
  state.counters["active"] = fit.summary.active_direction_count;
  state.counters["residual"] = fit.summary.relative_rms_residual;
}
BENCHMARK(BM_FitNonNegative)
    ->ArgNames({"samples", "directions"})
    ->Args({2000, 256})
    ->Args({500, 512})
    ->Args({2000, 512})
    ->Args({8000, 512})
    ->Unit(benchmark::kMillisecond);

// RelightNonNegative at 640x480 with lights fitted to both frames (2000 samples, 512 directions),
// the default ratio filter. Counter: active directions of the source's light.
void BM_RelightNonNegative(benchmark::State& state) {
  const Fixture& f = Data();
  const Prepared& p = PreparedData();
  SamplePointSelector selector({.count = 2000, .seed = 3});
  const std::vector<cv::Point> points = selector.Update(f.src.object_mask & p.normals.valid);
  const NonNegativeLightResult src =
      FitNonNegativeLight(GatherObservations(f.src.radiance, p.normals.normal_in_camera, f.src.albedo, {}, points));
  const NonNegativeLightResult dst =
      FitNonNegativeLight(GatherObservations(f.dst.radiance, f.dst.normal_in_camera, f.dst.albedo, {}, points));
  for (auto _ : state) {
    const RelightResult r =
        RelightNonNegative(f.src.radiance, p.normals.normal_in_camera, f.src.object_mask, src.light, dst.light);
    benchmark::DoNotOptimize(r.relit.pixels.data);
  }
  state.counters["active"] = src.summary.active_direction_count;
}
BENCHMARK(BM_RelightNonNegative)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace relume::processing

BENCHMARK_MAIN();
