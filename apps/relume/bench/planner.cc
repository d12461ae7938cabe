// `planner`: each skip the stage planner makes, timed with the skip and without it (forced),
// with the error against the truth both ways, on a scene where the skip applies. Each skip is
// decided by the library function the pipelines use:
//   merge      capture::PlanBracket (one exposure when the scene's range fits it), then
//              calibration::MergeHdr of that frame, against the usual 5-frame bracket;
//   irm        irm::BuildIrms (one IRM when no sample is in cast shadow; forced: four);
//   sh-order   processing::FitShKnownAlbedo (order 1 when the normals cannot support 2;
//              forced: the conditioning thresholds off);
//   denoise    processing::EstimateDepthNoise below kDenoiseSkipBelowAt1mM (the SH pipeline's
//              test; forced: the bilateral and temporal filters run);
//   radiosity  radiosity::EstimateReflectance's indirect-share test (EstimateIndirectShare;
//              forced: tolerance 0, radiosity iterated);
//   reuse      StageCache::Run (an unchanged stage is read back, not recomputed; forced: --force).
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "apps/relume/bench/bench.h"
#include "apps/relume/bench/irm.h"
#include "apps/relume/bench/radiosity.h"
#include "apps/relume/bench/sh.h"
#include "calibration/hdr_merge.h"
#include "calibration/image_file.h"
#include "calibration/testing/synthetic_bracket.h"
#include "capture/bracket_planner.h"
#include "core/error.h"
#include "pipeline/stage_cache.h"
#include "processing/depth_filter.h"

namespace relume::app::bench {
namespace {

namespace fs = std::filesystem;
namespace ct = calibration::testing;
using pipeline::StageCache;
using pipeline::StageKey;
using pipeline::StageStore;

void AddPair(std::vector<Row>& rows, const std::string& skip, const std::string& scene, double skip_s, double forced_s,
             double skip_error, double forced_error, const std::string& metric, const std::string& skip_notes,
             const std::string& forced_notes) {
  const std::string saved = "saved " + Format(forced_s - skip_s) + " s (" + Format(forced_s / skip_s) + "x)";
  rows.push_back({"planner", "skip: " + skip, scene, skip_s, 1.0 / skip_s, "runs/s", skip_error, metric,
                  skip_notes + "; " + saved});
  rows.push_back(
      {"planner", "forced: " + skip, scene, forced_s, 1.0 / forced_s, "runs/s", forced_error, metric, forced_notes});
}

// One exposure instead of a merge: a low-range scene that the bracket planner fits into one frame.
void MergeSkip(bool quick, std::vector<Row>& rows) {
  ct::SceneOptions scene;
  scene.width = quick ? 640 : 1024;
  scene.height = quick ? 480 : 768;
  scene.dynamic_range = 6.0;
  const cv::Mat radiance = ct::MakeHdrRadiance(scene);
  double max_radiance = 0.0;
  cv::minMaxLoc(radiance.reshape(1), nullptr, &max_radiance);
  const ct::SyntheticResponse response{ct::ResponseShape::kGamma};
  ct::NoiseOptions noise;
  noise.shot_noise = 1e-4;
  noise.read_noise = 5e-4;
  const double metering_s = 0.5 / max_radiance;
  const CameraImage metering = ct::RenderBracket(radiance, {metering_s}, response, noise).front();
  const capture::BracketPlannerOptions options;
  const capture::MeteringStats stats =
      capture::MeasureMeteringFrame(metering, 1.0, options, [&](double y) { return response.Inverse(1, y); });
  drivers::ExposureCapabilities caps;
  caps.control = drivers::ExposureControl::kContinuous;
  caps.min_exposure_time_s = 10e-6;
  caps.max_exposure_time_s = 10.0;
  const capture::BracketPlan plan = capture::PlanBracket(stats, caps, metering_s, 0.0, options);
  if (plan.exposures.size() != 1 || !plan.exposures.front().exposure_time_s) {
    throw InvalidArgumentError("bench planner: the low-range scene did not fit one exposure (" + plan.reason + ")");
  }
  const std::vector<double> one = {*plan.exposures.front().exposure_time_s};
  const std::vector<double> bracket = ct::BracketExposures(5, 2.0, one.front());
  const std::vector<CameraImage> one_frame = ct::RenderBracket(radiance, one, response, noise);
  const std::vector<CameraImage> frames = ct::RenderBracket(radiance, bracket, response, noise);
  const calibration::CameraResponse truth = ct::TrueInverseResponse(response);
  const cv::Mat mask = ct::WellExposedMask(radiance, one, response);
  calibration::HdrMergeResult a, b;
  const int repeats = quick ? 5 : 7;
  const double skip_s = BestSeconds(repeats, [&] { a = calibration::MergeHdr(one_frame, one, truth); });
  const double forced_s = BestSeconds(repeats, [&] { b = calibration::MergeHdr(frames, bracket, truth); });
  double capture_s = 0.0;
  for (const double t : bracket) capture_s += t;
  AddPair(rows, "single exposure instead of a merge",
          "scene range " + Format(plan.scene_range_stops) + " stops, " + std::to_string(scene.width) + "x" +
              std::to_string(scene.height) + ", noisy, true response",
          skip_s, forced_s, ct::CompareRadiance(a.radiance.pixels, radiance, mask).mean_relative,
          ct::CompareRadiance(b.radiance.pixels, radiance, mask).mean_relative, "mean relative radiance error",
          "PlanBracket: " + plan.reason + "; exposure " + Format(one.front()) + " s",
          "5 frames 2 EV apart (" + Format(capture_s) + " s of exposure to capture)");
}

// One IRM instead of four: high southern suns on a lone building, no cast shadow in either view.
void IrmSkip(bool quick, std::vector<Row>& rows) {
  const IrmScene s(quick ? 200 : 400, quick ? 140 : 280,
                   {irm::testing::SunFromAzimuthElevationDeg(170, 70), {900, 900, 900}, {30, 30, 40}},
                   {irm::testing::SunFromAzimuthElevationDeg(190, 75), {1000, 1000, 1000}, {25, 25, 35}}, 0,
                   /*with_neighbour=*/false);
  irm::RelightOptions options;
  options.sky_samples = 0;  // the renderer's sky is open here
  const irm::View source = s.SourceView(), target = s.TargetView();
  const irm::ViewGeometry gs = irm::ComputeViewGeometry(*s.caster, source, options);
  const irm::ViewGeometry gt = irm::ComputeViewGeometry(*s.caster, target, options);
  auto run = [&](const irm::RelightOptions& o, irm::RelightResult* result) {
    irm::RelightSummary summary;
    const irm::IrmSet irms = irm::BuildIrmsFromViews(*s.caster, source, target, gs, gt, o, &summary);
    *result = irm::RelightPixels(*s.caster, source, target, gs, gt, irms, o, summary);
  };
  irm::RelightOptions forced = options;
  forced.irm.single_map_without_shadow = false;
  irm::RelightResult a, b;
  const int repeats = quick ? 2 : 3;
  const double skip_s = BestSeconds(repeats, [&] { run(options, &a); });
  const double forced_s = BestSeconds(repeats, [&] { run(forced, &b); });
  if (!a.irms.single_map) throw InvalidArgumentError("bench planner: the no-shadow IRM scene has cast shadows");
  const metrics::SunRegionErrors ea = CompareRelit(s, a), eb = CompareRelit(s, b);
  AddPair(rows, "one IRM instead of four (no cast shadow)",
          "lone building, suns 170/70 and 190/75 deg (az/el), IRM build + relight (per-vertex rays shared)", skip_s,
          forced_s, ea.all, eb.all, "relit relative RMS, all relit pixels",
          std::to_string(gs.visible_in_cast_shadow) + " + " + std::to_string(gt.visible_in_cast_shadow) +
              " visible vertices in cast shadow; " + Describe(ea),
          Describe(eb));
}

// SH order 1 instead of 2: the normals cover only a cap of the big sphere (about 37 deg).
void ShOrderSkip(bool quick, std::vector<Row>& rows) {
  const ShScene s(quick ? 320 : 640, quick ? 240 : 480);
  cv::Mat mask = cv::Mat::zeros(s.src.object_mask.size(), CV_8UC1);
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      const cv::Vec3f n = s.src.normal_in_camera.at<cv::Vec3f>(y, x);
      if (s.src.object_id.at<int>(y, x) == processing::testing::kBigSphere && n[2] < -0.8f)
        mask.at<std::uint8_t>(y, x) = 255;
    }
  }
  const cv::Mat previous = processing::testing::AddKinectDepthNoise(s.src.depth_m, 41);
  const cv::Mat noisy = processing::testing::AddKinectDepthNoise(s.src.depth_m, 42);
  processing::ShEstimatorOptions options;
  processing::ShEstimatorOptions forced = options;
  forced.fit.fit.max_condition_number = 1e300;
  forced.fit.fit.min_solid_angle_order2_sr = 0.0;
  const int repeats = quick ? 3 : 5;
  const ShChainResult a = RunShChain(s, options, previous, noisy, mask, repeats);
  const ShChainResult b = RunShChain(s, forced, previous, noisy, mask, repeats);
  if (a.estimate.summary.order_used != 1) {
    throw InvalidArgumentError("bench planner: the SH cap scene kept order " +
                               std::to_string(a.estimate.summary.order_used) + " (" + a.estimate.summary.message + ")");
  }
  AddPair(rows, "SH order 1 instead of 2 (normals do not support 2)",
          "cap of the big sphere (normal within 37 deg of the view), Kinect noise, whole chain per frame", a.seconds,
          b.seconds, a.relit_rms, b.relit_rms, "relit relative RMS",
          "order " + std::to_string(a.estimate.summary.order_used) + ": " + a.estimate.summary.message +
              "; irradiance RMS on the cap " + Format(a.irradiance_rms) + ", on every object normal " +
              Format(IrradianceRelativeRms(s, a.estimate.light, s.src.object_mask)),
          "order " + std::to_string(b.estimate.summary.order_used) + ", condition " +
              Format(b.estimate.summary.condition_number) + "; irradiance RMS on the cap " + Format(b.irradiance_rms) +
              ", on every object normal " + Format(IrradianceRelativeRms(s, b.estimate.light, s.src.object_mask)));
}

// No depth filters when the depth has no noise: the analytic scene's exact depth.
void DenoiseSkip(bool quick, std::vector<Row>& rows) {
  const ShScene s(quick ? 320 : 640, quick ? 240 : 480);
  const processing::DepthNoiseEstimate noise = processing::EstimateDepthNoise(s.src.depth_m);
  if (!noise.NoiseFree(processing::kDenoiseSkipBelowAt1mM)) {
    throw InvalidArgumentError("bench planner: the noise-free SH scene's depth measured " + noise.Describe());
  }
  processing::ShEstimatorOptions skip;
  skip.geometry.filter_depth = false;
  const processing::ShEstimatorOptions forced;  // filters on
  const int repeats = quick ? 3 : 5;
  const ShChainResult a = RunShChain(s, skip, s.src.depth_m, s.src.depth_m, s.src.object_mask, repeats);
  const ShChainResult b = RunShChain(s, forced, s.src.depth_m, s.src.depth_m, s.src.object_mask, repeats);
  AddPair(rows, "no depth filters (depth noise below " + Format(processing::kDenoiseSkipBelowAt1mM * 1e3) + " mm)",
          "noise-free analytic RGB-D scene, whole chain per frame", a.seconds, b.seconds, a.relit_rms, b.relit_rms,
          "relit relative RMS", "measured depth noise " + noise.Describe(), "bilateral + temporal filters run");
}

// Area-weighted mean of the patches' true albedo (the scale the albedo errors compare with).
double MeanTrueAlbedo(const RadiosityRoom& room) {
  double sum = 0.0, area = 0.0;
  const std::vector<radiosity::Rgb> albedo = room.hierarchy->LeafAlbedo();
  for (int p = 0; p < room.hierarchy->LeafCount(); ++p) {
    sum += room.hierarchy->leaf(p).area_m2 * albedo[static_cast<std::size_t>(p)].mean();
    area += room.hierarchy->leaf(p).area_m2;
  }
  return sum / area;
}

// No radiosity when the indirect share is below tolerance: the test room with dark materials.
void RadiositySkip(bool quick, std::vector<Row>& rows) {
  const double scale = 0.05, tolerance = 0.05;
  const RadiosityRoom room(2, 0.6, scale);
  radiosity::ReflectanceOptions options;
  options.indirect_skip_tolerance = tolerance;
  radiosity::ReflectanceOptions forced = options;
  forced.indirect_skip_tolerance = 0.0;
  radiosity::ReflectanceResult a, b;
  const int repeats = quick ? 1 : 2;
  const double skip_s = BestSeconds(
      repeats, [&] { a = radiosity::EstimateReflectance(*room.hierarchy, *room.caster, room.photos, options); });
  const double forced_s = BestSeconds(
      repeats, [&] { b = radiosity::EstimateReflectance(*room.hierarchy, *room.caster, room.photos, forced); });
  if (!a.radiosity_skipped) {
    throw InvalidArgumentError("bench planner: radiosity was not skipped in the dark room (indirect share " +
                               Format(a.indirect.indirect_share) + ", tolerance " + Format(tolerance) + ")");
  }
  AddPair(rows, "no radiosity (indirect share below tolerance)",
          "test room, albedo x " + Format(scale) + ", 2 lamp images, patch edge 600 mm, tolerance " + Format(tolerance),
          skip_s, forced_s, MeanAlbedoError(room, a), MeanAlbedoError(room, b), "mean albedo error",
          "indirect share estimate " + Format(a.indirect.indirect_share) + ", mean true albedo " +
              Format(MeanTrueAlbedo(room)) + "; " + a.reason,
          std::to_string(b.iterations) + " radiosity iterations");
}

// Reuse of an unchanged stage: the SH chain as a cached stage writing its relit image.
void ReuseSkip(bool quick, std::vector<Row>& rows) {
  const ShScene s(quick ? 320 : 640, quick ? 240 : 480);
  const cv::Mat previous = processing::testing::AddKinectDepthNoise(s.src.depth_m, 41);
  const cv::Mat noisy = processing::testing::AddKinectDepthNoise(s.src.depth_m, 42);
  const fs::path root = fs::temp_directory_path() / ("relume-bench-stages-" + std::to_string(::getpid()));
  fs::remove_all(root);
  StageKey key;
  key.Add("stage", "bench-sh-relight-v1").Add("width", s.scene.intrinsics.width).Add("noise_seed", 42);
  auto produce = [&](const fs::path& dir) {
    const ShChainResult r = RunShChain(s, {}, previous, noisy, s.src.object_mask, 1);
    const processing::RelightResult relit = processing::RelightSh(s.src.radiance, r.estimate.normals.normal_in_camera,
                                                                  s.src.object_mask, r.estimate.light, s.dst_light);
    calibration::SaveRadianceExr(relit.relit, (dir / "relit.exr").string());  // NaN where not relit
  };
  auto read_back = [&](const StageStore::Result& result) {
    processing::RelightResult r;
    r.relit = calibration::LoadRadianceExr((result.dir / "relit.exr").string());
    r.valid = cv::Mat::zeros(r.relit.pixels.size(), CV_8UC1);
    for (int y = 0; y < r.valid.rows; ++y) {
      for (int x = 0; x < r.valid.cols; ++x) {
        const cv::Vec3f v = r.relit.pixels.at<cv::Vec3f>(y, x);
        if (std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2])) r.valid.at<std::uint8_t>(y, x) = 255;
      }
    }
    return RelitRelativeRms(s, r);
  };
  double forced_error = 0.0, skip_error = 0.0;
  bool reused = true;
  const int repeats = quick ? 2 : 3;
  const double forced_s = BestSeconds(repeats, [&] {
    StageCache cache(root, /*reuse=*/false);
    forced_error = read_back(cache.Run("sh-relight", key, produce));
  });
  const double skip_s = BestSeconds(repeats, [&] {
    StageCache cache(root, /*reuse=*/true);
    const StageStore::Result result = cache.Run("sh-relight", key, produce);
    reused = reused && result.reused;
    skip_error = read_back(result);
  });
  fs::remove_all(root);
  if (!reused) throw InvalidArgumentError("bench planner: the unchanged stage was recomputed");
  AddPair(rows, "reuse of an unchanged stage",
          "SH chain + relight as a cached stage (EXR out), " + std::to_string(s.scene.intrinsics.width) + "x" +
              std::to_string(s.scene.intrinsics.height) + " noisy frame",
          skip_s, forced_s, skip_error, forced_error, "relit relative RMS",
          "StageCache::Run found the completed stage (same key)", "recomputed (--force)");
}

}  // namespace

void BenchPlanner(bool quick, std::vector<Row>& rows) {
  MergeSkip(quick, rows);
  IrmSkip(quick, rows);
  ShOrderSkip(quick, rows);
  DenoiseSkip(quick, rows);
  RadiositySkip(quick, rows);
  ReuseSkip(quick, rows);
}

}  // namespace relume::app::bench
