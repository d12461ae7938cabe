// End-to-end accuracy of the SH chain against analytic ground truth: depth -> filter ->
// normals -> fit -> relight, compared with the scene rendered under the destination light.
// The numbers printed here are the ones quoted in docs/processing-sh.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>

#include "processing/relight.h"
#include "processing/sh_pipeline.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

ShRgb SkyLight(const Eigen::Vector3d& sun_dir_in_map) {
  testing::SkySunOptions sky;
  sky.sun_dir_in_map = sun_dir_in_map.normalized();
  return ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, sky), testing::CameraFromMap());
}

// Source: sun high on the right; destination: low sun from the left and behind.
const ShRgb& SrcLight() {
  static const ShRgb light = SkyLight({0.6, -0.4, 0.7});
  return light;
}
const ShRgb& DstLight() {
  static const ShRgb light = SkyLight({-0.8, 0.3, 0.35});
  return light;
}

struct Errors {
  double irradiance_rel_rms = 0;  // fitted E(true n) vs true E, over the object
  double relit_rel_rms = 0;       // relit vs truth under the destination light
  double baseline_rel_rms = 0;    // source image vs that truth (no relighting)
  double coverage = 0;            // relit pixels / object pixels
};

double RelativeRms(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  double error = 0.0, total = 0.0;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (!mask.at<unsigned char>(y, x)) continue;
      const cv::Vec3f d = a.at<cv::Vec3f>(y, x) - b.at<cv::Vec3f>(y, x);
      error += d.dot(d);
      total += b.at<cv::Vec3f>(y, x).dot(b.at<cv::Vec3f>(y, x));
    }
  }
  return std::sqrt(error / total);
}

Errors Evaluate(const testing::SyntheticFrame& src, const testing::SyntheticFrame& dst_truth, const ShRgb& src_light,
                const ShRgb& dst_light, const NormalMap& normals) {
  Errors e;
  cv::Mat fitted_e(src.irradiance.size(), CV_32FC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < fitted_e.rows; ++y) {
    for (int x = 0; x < fitted_e.cols; ++x) {
      if (!src.object_mask.at<unsigned char>(y, x)) continue;
      const cv::Vec3f n = src.normal_in_camera.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d value = ShIrradiance(src_light, Eigen::Vector3d(n[0], n[1], n[2]));
      fitted_e.at<cv::Vec3f>(y, x) = cv::Vec3f(value.x(), value.y(), value.z());
    }
  }
  e.irradiance_rel_rms = RelativeRms(fitted_e, src.irradiance, src.object_mask);
  const RelightResult relit = RelightSh(src.radiance, normals.normal_in_camera, src.object_mask, src_light, dst_light);
  e.relit_rel_rms = RelativeRms(relit.relit.pixels, dst_truth.radiance.pixels, relit.valid);
  e.baseline_rel_rms = RelativeRms(src.radiance.pixels, dst_truth.radiance.pixels, relit.valid);
  e.coverage = static_cast<double>(relit.summary.relit_pixel_count) / cv::countNonZero(src.object_mask);
  return e;
}

void Print(const char* name, const Errors& e, const ShFitSummary& summary) {
  std::printf("%-52s irradiance %.4f  relit %.4f  baseline %.4f  coverage %.3f\n    fit: %s\n", name,
              e.irradiance_rel_rms, e.relit_rel_rms, e.baseline_rel_rms, e.coverage, summary.BriefReport().c_str());
}

// The chain's defaults, with the normal window stated (3 px, the default) because the
// numbers below depend on it.
ShEstimatorOptions Options(int segment_count = 4) {
  ShEstimatorOptions options;
  options.geometry.normals.window_radius_px = 3;
  options.segmentation.segment_count = segment_count;
  return options;
}

class ShAccuracyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    src_ = testing::RenderScene(scene_, SrcLight());
    dst_ = testing::RenderScene(scene_, DstLight());
  }
  testing::SceneOptions scene_;
  testing::SyntheticFrame src_, dst_;
};

TEST_F(ShAccuracyTest, KnownAlbedoNoiseFreeMeetsTheTwoPercentGoal) {
  // The estimator measures the stream's first frame, finds exact depth noise-free and does not
  // filter it, so the normals beside the box's creases come from 3 x 3 boxes on each face
  // (NormalOptions::refine_creases), as the sh pipeline runs such depth.
  ShLightEstimator estimator(Options());
  const ShFrameEstimate estimate =
      estimator.EstimateKnownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask, src_.albedo);
  ASSERT_TRUE(estimate.summary.usable);
  EXPECT_FALSE(estimate.depth_filtered);
  ASSERT_TRUE(estimate.depth_noise.has_value());
  EXPECT_LT(estimate.depth_noise->sigma_at_1m_m, kDenoiseSkipBelowAt1mM) << estimate.depth_noise->Describe();
  EXPECT_GT(estimate.normals.crease_count, 0);
  const Errors e = Evaluate(src_, dst_, estimate.light, DstLight(), estimate.normals);
  Print("ideal, known albedo, 2000 samples, dst SH given", e, estimate.summary);
  // With the true normals the only error left is the light's.
  NormalMap true_normals;
  true_normals.normal_in_camera = src_.normal_in_camera;
  const Errors exact_normals = Evaluate(src_, dst_, estimate.light, DstLight(), true_normals);
  Print("ideal, known albedo, relit with the true normals", exact_normals, estimate.summary);
  EXPECT_LT(exact_normals.relit_rel_rms, 0.01);
  EXPECT_LT(e.relit_rel_rms, 0.008);
  EXPECT_LT(e.irradiance_rel_rms, 0.005);
  EXPECT_GT(e.baseline_rel_rms, 5 * e.relit_rel_rms);
  EXPECT_GT(e.coverage, 0.98);

  // Filtered whatever the noise: the filters round the creases and the normals blend the faces
  // over the window.
  ShEstimatorOptions filtered = Options();
  filtered.geometry.skip_filter_below_at_1m_m = 0.0;
  ShLightEstimator filtered_estimator(filtered);
  const ShFrameEstimate blended = filtered_estimator.EstimateKnownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics,
                                                                         src_.object_mask, src_.albedo);
  EXPECT_TRUE(blended.depth_filtered);
  EXPECT_FALSE(blended.depth_noise.has_value());
  EXPECT_EQ(blended.normals.crease_count, 0);
  const Errors b = Evaluate(src_, dst_, blended.light, DstLight(), blended.normals);
  Print("ideal, depth filtered anyway", b, blended.summary);
  EXPECT_LT(b.relit_rel_rms, 0.02);
  EXPECT_LT(e.relit_rel_rms, 0.5 * b.relit_rel_rms);

  ShEstimatorOptions wide = filtered;
  wide.geometry.normals.window_radius_px = 6;
  ShLightEstimator wide_estimator(wide);
  const ShFrameEstimate wide_estimate =
      wide_estimator.EstimateKnownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask, src_.albedo);
  Print("ideal, depth filtered, normal window 6 px at 320x240",
        Evaluate(src_, dst_, wide_estimate.light, DstLight(), wide_estimate.normals), wide_estimate.summary);
}

TEST_F(ShAccuracyTest, ReferenceSegmentNoiseFree) {
  ShLightEstimator estimator(Options());
  const ShFrameEstimate estimate = estimator.EstimateWithReferenceSegment(
      src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask, scene_.big_sphere_albedo);
  ASSERT_TRUE(estimate.summary.usable);
  const Errors e = Evaluate(src_, dst_, estimate.light, DstLight(), estimate.normals);
  Print("ideal, largest segment with known reflectance", e, estimate.summary);
  // Goal 2 %; measured 0.75 % (2.0 % when the exact depth was filtered and the creases blended).
  EXPECT_LT(e.relit_rel_rms, 0.01);
}

TEST_F(ShAccuracyTest, UnknownAlbedoNoiseFree) {
  ShEstimatorOptions options = Options(3);
  ShLightEstimator src_estimator(options), dst_estimator(options);
  const ShFrameEstimate src =
      src_estimator.EstimateUnknownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask);
  const ShFrameEstimate dst =
      dst_estimator.EstimateUnknownAlbedo(dst_.radiance, dst_.depth_m, scene_.intrinsics, dst_.object_mask);
  ASSERT_TRUE(src.summary.converged) << src.summary.BriefReport();
  ASSERT_TRUE(dst.summary.converged) << dst.summary.BriefReport();
  // Destination from a second estimate made the same way: the per-channel scale cancels.
  const Errors e = Evaluate(src_, dst_, src.light, dst.light, src.normals);
  Print("ideal, unknown albedo, dst from a second estimate", e, src.summary);
  EXPECT_LT(e.relit_rel_rms, 0.01);  // measured 0.61 %
  // With the reference segment's true albedo the light itself is absolute.
  options.fit.reference_albedo = scene_.big_sphere_albedo;
  ShLightEstimator absolute(options);
  const ShFrameEstimate abs =
      absolute.EstimateUnknownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask);
  const Errors ea = Evaluate(src_, dst_, abs.light, DstLight(), abs.normals);
  Print("ideal, unknown albedo + reference albedo, dst SH given", ea, abs.summary);
  EXPECT_LT(ea.relit_rel_rms, 0.01);  // goal 2 %; measured 0.69 %
  EXPECT_LT(ea.irradiance_rel_rms, 0.01);
}

// One stream, four segments for three objects (one object split between two segments): the
// destination frame comes first and becomes the stream's albedo reference, the source is fitted
// with its segment albedos (ShEstimatorOptions::share_albedo), so the two lights settle the
// albedo-light ambiguity the same way.
TEST_F(ShAccuracyTest, UnknownAlbedoSharedAlongTheStream) {
  ShLightEstimator stream(Options(4));
  const ShFrameEstimate dst =
      stream.EstimateUnknownAlbedo(dst_.radiance, dst_.depth_m, scene_.intrinsics, dst_.object_mask);
  const ShFrameEstimate src =
      stream.EstimateUnknownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask);
  ASSERT_TRUE(dst.summary.usable) << dst.summary.BriefReport();
  ASSERT_TRUE(src.summary.usable) << src.summary.BriefReport();
  EXPECT_FALSE(dst.albedo_shared);
  EXPECT_TRUE(src.albedo_shared);
  EXPECT_EQ(src.segment_albedo, dst.segment_albedo);
  const Errors shared = Evaluate(src_, dst_, src.light, dst.light, src.normals);
  Print("ideal, unknown albedo shared along the stream", shared, src.summary);
  EXPECT_LT(shared.relit_rel_rms, 0.01);

  // Each frame on its own (share_albedo = false), for the record beside it.
  ShEstimatorOptions own_options = Options(4);
  own_options.share_albedo = false;
  ShLightEstimator own(own_options);
  const ShFrameEstimate own_dst =
      own.EstimateUnknownAlbedo(dst_.radiance, dst_.depth_m, scene_.intrinsics, dst_.object_mask);
  const ShFrameEstimate own_src =
      own.EstimateUnknownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask);
  EXPECT_FALSE(own_src.albedo_shared);
  Print("ideal, unknown albedo, each frame on its own", Evaluate(src_, dst_, own_src.light, own_dst.light, src.normals),
        own_src.summary);

  // Reset starts a new stream: its next frame is a new reference.
  stream.Reset();
  EXPECT_FALSE(
      stream.EstimateUnknownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask).albedo_shared);
}

TEST_F(ShAccuracyTest, KinectNoiseThroughTheFilters) {
  // Two noisy frames of the static scene, so the temporal filter takes part.
  ShLightEstimator estimator(Options());
  estimator.EstimateKnownAlbedo(src_.radiance, testing::AddKinectDepthNoise(src_.depth_m, 1), scene_.intrinsics,
                                src_.object_mask, src_.albedo);
  const ShFrameEstimate estimate = estimator.EstimateKnownAlbedo(
      src_.radiance, testing::AddKinectDepthNoise(src_.depth_m, 2), scene_.intrinsics, src_.object_mask, src_.albedo);
  ASSERT_TRUE(estimate.summary.usable);
  EXPECT_TRUE(estimate.depth_filtered);    // the first frame's noise decided it
  EXPECT_GT(estimate.samples_kept, 1000);  // most sample points stay from frame to frame
  const Errors e = Evaluate(src_, dst_, estimate.light, DstLight(), estimate.normals);
  Print("Kinect noise, known albedo, filters on", e, estimate.summary);
  EXPECT_LT(e.relit_rel_rms, 0.5 * e.baseline_rel_rms);

  ShEstimatorOptions unfiltered_options = Options();
  unfiltered_options.geometry.filter_depth = false;
  ShLightEstimator unfiltered(unfiltered_options);
  const ShFrameEstimate raw = unfiltered.EstimateKnownAlbedo(
      src_.radiance, testing::AddKinectDepthNoise(src_.depth_m, 2), scene_.intrinsics, src_.object_mask, src_.albedo);
  const Errors er = Evaluate(src_, dst_, raw.light, DstLight(), raw.normals);
  Print("Kinect noise, known albedo, filters off", er, raw.summary);
  EXPECT_LT(e.relit_rel_rms, er.relit_rel_rms);

  ShEstimatorOptions options = Options(3);
  ShLightEstimator src_estimator(options), dst_estimator(options);
  const ShFrameEstimate src = src_estimator.EstimateUnknownAlbedo(
      src_.radiance, testing::AddKinectDepthNoise(src_.depth_m, 3), scene_.intrinsics, src_.object_mask);
  const ShFrameEstimate dst = dst_estimator.EstimateUnknownAlbedo(
      dst_.radiance, testing::AddKinectDepthNoise(dst_.depth_m, 4), scene_.intrinsics, dst_.object_mask);
  const Errors eu = Evaluate(src_, dst_, src.light, dst.light, src.normals);
  Print("Kinect noise, unknown albedo, dst from a second estimate", eu, src.summary);
  EXPECT_LT(eu.relit_rel_rms, 0.5 * eu.baseline_rel_rms);
}

// Destination light from an environment map: the truth is the brute-force irradiance of the
// map (not its SH projection), so the 9-coefficient truncation error is included.
TEST_F(ShAccuracyTest, EnvironmentMapDestinationAgainstBruteForceTruth) {
  testing::SkySunOptions sky;
  sky.sun_dir_in_map = Eigen::Vector3d(-0.5, 0.6, 0.3).normalized();
  const RadianceImage map = testing::MakeSkySunMap(96, 48, sky);
  const ShRgb dst_light = ProjectEnvironmentMap(map, testing::CameraFromMap());
  ShLightEstimator estimator(Options());
  const ShFrameEstimate estimate =
      estimator.EstimateKnownAlbedo(src_.radiance, src_.depth_m, scene_.intrinsics, src_.object_mask, src_.albedo);
  const RelightResult relit =
      RelightSh(src_.radiance, estimate.normals.normal_in_camera, src_.object_mask, estimate.light, dst_light);
  double error = 0.0, baseline = 0.0, total = 0.0;
  int count = 0;
  for (int y = 0; y < src_.object_mask.rows; y += 4) {
    for (int x = 0; x < src_.object_mask.cols; x += 4) {
      if (!relit.valid.at<unsigned char>(y, x)) continue;
      const cv::Vec3f n = src_.normal_in_camera.at<cv::Vec3f>(y, x), a = src_.albedo.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d e = IntegrateIrradiance(map, testing::CameraFromMap(), Eigen::Vector3d(n[0], n[1], n[2]));
      const cv::Vec3f truth(a[0] * e.x() / M_PI, a[1] * e.y() / M_PI, a[2] * e.z() / M_PI);
      const cv::Vec3f d = relit.relit.pixels.at<cv::Vec3f>(y, x) - truth;
      const cv::Vec3f b = src_.radiance.pixels.at<cv::Vec3f>(y, x) - truth;
      error += d.dot(d);
      baseline += b.dot(b);
      total += truth.dot(truth);
      ++count;
    }
  }
  const double rel = std::sqrt(error / total), base = std::sqrt(baseline / total);
  std::printf("%-52s relit %.4f  baseline %.4f  (%d pixels)\n", "ideal, known albedo, dst env map (brute-force truth)",
              rel, base, count);
  EXPECT_LT(rel, 0.03);
  EXPECT_LT(rel, 0.2 * base);
}

}  // namespace
}  // namespace relume::processing
