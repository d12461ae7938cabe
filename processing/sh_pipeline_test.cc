#include "processing/sh_pipeline.h"

#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

ShRgb SkyLight() {
  return ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, {}), testing::CameraFromMap());
}

TEST(ShPipelineTest, EmptyMaskIsNotUsableAndHasNoNan) {
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  const cv::Mat empty = cv::Mat::zeros(frame.object_mask.size(), CV_8UC1);
  ShLightEstimator estimator;
  for (const ShFrameEstimate& e :
       {estimator.EstimateKnownAlbedo(frame.radiance, frame.depth_m, scene.intrinsics, empty, frame.albedo),
        estimator.EstimateWithReferenceSegment(frame.radiance, frame.depth_m, scene.intrinsics, empty,
                                               scene.big_sphere_albedo),
        estimator.EstimateUnknownAlbedo(frame.radiance, frame.depth_m, scene.intrinsics, empty)}) {
    EXPECT_FALSE(e.summary.usable);
    EXPECT_TRUE(e.light.isZero());
    EXPECT_FALSE(e.summary.message.empty());
    EXPECT_EQ(cv::countNonZero(e.normals.valid), 0);
  }
}

TEST(ShPipelineTest, WorksOnTheRegionOfInterestOnly) {
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  ShLightEstimator estimator;
  const ShFrameEstimate e =
      estimator.EstimateKnownAlbedo(frame.radiance, frame.depth_m, scene.intrinsics, frame.object_mask, frame.albedo);
  ASSERT_TRUE(e.summary.usable);
  EXPECT_LT(e.roi.area(), frame.object_mask.total());
  EXPECT_TRUE(std::isnan(e.depth_m.at<float>(0, 0)));  // the wall's corner is outside the roi
  // Every object pixel with a same-surface neighbour has a normal.
  EXPECT_GT(cv::countNonZero(e.normals.valid & frame.object_mask), 0.98 * cv::countNonZero(frame.object_mask));
}

// The geometry step over a stream of one static view (the chain's state made explicit): with
// the temporal filter on, the first frame's normals (nothing to blend with) are not lent; the
// second frame's are, to the third; depth that moves is estimated again; the whole frame is
// worked on without a region, the region's neighbourhood with one. The depth is exact, so the
// filters are forced on (skip_filter_below_at_1m_m = 0) to carry their state.
TEST(ShPipelineTest, GeometryStepCarriesItsStateFromFrameToFrame) {
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  ShGeometryOptions options;
  options.skip_filter_below_at_1m_m = 0.0;
  const ShGeometry first = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, nullptr);
  EXPECT_EQ(first.roi, cv::Rect(0, 0, frame.depth_m.cols, frame.depth_m.rows));
  EXPECT_EQ(first.temporal_blended, 0);
  EXPECT_FALSE(first.depth_changed_fraction.has_value());
  EXPECT_GT(first.normals.integral_count + first.normals.cross_count, 0);
  const ShGeometry second = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &first);
  EXPECT_GT(second.temporal_blended, 0);
  ASSERT_TRUE(second.depth_changed_fraction.has_value());
  EXPECT_EQ(*second.depth_changed_fraction, 0.0);
  EXPECT_FALSE(second.normals_reused);  // the first frame was not blended
  const ShGeometry third = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &second);
  EXPECT_TRUE(third.normals_reused);
  EXPECT_EQ(third.normals.normal_in_camera.data, second.normals.normal_in_camera.data);  // shared, not copied
  EXPECT_EQ(cv::countNonZero(third.mask), cv::countNonZero(second.mask));
  // Without the temporal filter the first frame lends its normals.
  ShGeometryOptions no_temporal = options;
  no_temporal.temporal.weight = 0.0;
  const ShGeometry plain = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, no_temporal, nullptr);
  EXPECT_TRUE(EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, no_temporal, &plain).normals_reused);
  // The scene 5 cm further away: every pixel moved.
  const cv::Mat moved = frame.depth_m + 0.05;
  const ShGeometry after = EstimateShGeometry(moved, scene.intrinsics, {}, options, &third);
  EXPECT_GT(*after.depth_changed_fraction, 0.9);
  EXPECT_FALSE(after.normals_reused);
  // A region: filtering and normals on its grown bounding rectangle only.
  const ShGeometry region = EstimateShGeometry(frame.depth_m, scene.intrinsics, frame.object_mask, options, nullptr);
  EXPECT_LT(region.roi.area(), first.roi.area());
  EXPECT_EQ(cv::countNonZero(region.normals.valid(region.roi)), cv::countNonZero(region.normals.valid));
  // A frame of another size starts a new stream.
  PinholeIntrinsics k = scene.intrinsics;  // the top-left quarter, as a camera of its own
  k.width /= 2;
  k.height /= 2;
  const cv::Mat half = frame.depth_m(cv::Rect(0, 0, k.width, k.height)).clone();
  const ShGeometry other = EstimateShGeometry(half, k, {}, options, &third);
  EXPECT_EQ(other.temporal_blended, 0);
  EXPECT_FALSE(other.depth_changed_fraction.has_value());
  ShGeometryOptions bad = options;
  bad.reuse_sigmas = 0.0;
  EXPECT_THROW(EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, bad, nullptr), InvalidArgumentError);
}

// A previous frame read back from storage (the pipeline's stage folders) carries a loader
// instead of its normals: it is called only when the normals are reused. Depth only
// (estimate_normals false) estimates and reuses no normals. Filters forced on, as above.
TEST(ShPipelineTest, StoredNormalsAreReadOnlyWhenReused) {
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  ShGeometryOptions options;
  options.skip_filter_below_at_1m_m = 0.0;
  const ShGeometry first = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, nullptr);
  const ShGeometry second = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &first);
  int loads = 0;
  auto stored = [&](const ShGeometry& g) {
    ShGeometry s = g;
    s.normals = NormalMap();
    s.load_normals = [&loads, normals = g.normals] {
      ++loads;
      return normals;
    };
    return s;
  };
  const ShGeometry after_first = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &first);
  const ShGeometry stored_first = stored(first);
  const ShGeometry not_reused = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &stored_first);
  EXPECT_FALSE(not_reused.normals_reused);  // the first frame was not blended
  EXPECT_EQ(loads, 0);
  EXPECT_EQ(cv::countNonZero(not_reused.mask), cv::countNonZero(after_first.mask));
  const ShGeometry stored_second = stored(second);
  const ShGeometry reused = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &stored_second);
  EXPECT_TRUE(reused.normals_reused);
  EXPECT_EQ(loads, 1);
  EXPECT_EQ(reused.normals.normal_in_camera.data, second.normals.normal_in_camera.data);
  EXPECT_EQ(cv::countNonZero(reused.mask), cv::countNonZero(second.mask));

  ShGeometryOptions depth_only = options;
  depth_only.estimate_normals = false;
  const ShGeometry bare = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, depth_only, &second);
  EXPECT_GT(bare.temporal_blended, 0);  // the depth is still filtered
  EXPECT_FALSE(bare.normals_reused);
  EXPECT_EQ(bare.normals.integral_count + bare.normals.cross_count, 0);
  EXPECT_EQ(cv::countNonZero(bare.normals.valid), 0);
  EXPECT_EQ(cv::countNonZero(bare.mask), 0);
  EXPECT_EQ(bare.normals.normal_in_camera.size(), frame.depth_m.size());
}

// The crease refinement's 3 x 3 plane fits need depth without noise: the geometry step runs it
// on depth it does not filter, never on filtered depth (processing/normals.h, "Creases").
TEST(ShPipelineTest, CreasesAreRefinedOnlyOnDepthThatIsNotFiltered) {
  const testing::SceneOptions scene;  // two spheres and a box
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  ShGeometryOptions unfiltered;
  unfiltered.filter_depth = false;
  const ShGeometry exact = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, unfiltered, nullptr);
  EXPECT_GT(exact.normals.crease_count, 50);  // the box's edges
  ShGeometryOptions filtered;
  filtered.skip_filter_below_at_1m_m = 0.0;  // whatever the noise
  EXPECT_EQ(EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, filtered, nullptr).normals.crease_count, 0);
  ShGeometryOptions off = unfiltered;
  off.normals.refine_creases = false;
  const ShGeometry blended = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, off, nullptr);
  EXPECT_EQ(blended.normals.crease_count, 0);
  EXPECT_EQ(cv::countNonZero(blended.mask), cv::countNonZero(exact.mask));
  // Not filtered (filter_depth off) but noisy: the frame is measured over the whole frame, and
  // the refinement is skipped with the reason.
  EXPECT_FALSE(exact.creases_skipped_for_noise.has_value());
  const ShGeometry noisy =
      EstimateShGeometry(testing::AddKinectDepthNoise(frame.depth_m, 3), scene.intrinsics, {}, unfiltered, nullptr);
  ASSERT_TRUE(noisy.creases_skipped_for_noise.has_value());
  EXPECT_GT(noisy.creases_skipped_for_noise->sigma_at_1m_m, 5e-4);
  EXPECT_EQ(noisy.normals.crease_count, 0);
}

// A stream decides whether to filter on its first frame's own noise and keeps the decision:
// the frames after it inherit it through `previous`, whatever their own noise; a frame of
// another size starts a stream that decides again.
TEST(ShPipelineTest, StreamDecidesToFilterOnItsFirstFrame) {
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  const cv::Mat noisy = testing::AddKinectDepthNoise(frame.depth_m, 7);
  const ShGeometryOptions options;

  const ShGeometry exact = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, nullptr);
  EXPECT_FALSE(exact.depth_filtered);
  ASSERT_TRUE(exact.depth_noise.has_value());
  EXPECT_TRUE(exact.depth_noise->NoiseFree(options.skip_filter_below_at_1m_m)) << exact.depth_noise->Describe();
  EXPECT_GT(exact.normals.crease_count, 50);
  EXPECT_EQ(cv::countNonZero(exact.depth_m != frame.depth_m), 0);  // untouched
  const ShGeometry next = EstimateShGeometry(noisy, scene.intrinsics, {}, options, &exact);
  EXPECT_FALSE(next.depth_filtered);
  EXPECT_FALSE(next.depth_noise.has_value());
  EXPECT_EQ(next.temporal_blended, 0);

  const ShGeometry first = EstimateShGeometry(noisy, scene.intrinsics, {}, options, nullptr);
  EXPECT_TRUE(first.depth_filtered);
  ASSERT_TRUE(first.depth_noise.has_value());
  EXPECT_GT(first.depth_noise->sigma_at_1m_m, 1e-3) << first.depth_noise->Describe();  // Kinect: ~1.5 mm
  EXPECT_EQ(first.normals.crease_count, 0);
  const ShGeometry second = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, options, &first);
  EXPECT_TRUE(second.depth_filtered);
  EXPECT_GT(second.temporal_blended, 0);

  PinholeIntrinsics k = scene.intrinsics;  // the top-left quarter: a new stream
  k.width /= 2;
  k.height /= 2;
  const cv::Mat half = frame.depth_m(cv::Rect(0, 0, k.width, k.height)).clone();
  const ShGeometry other = EstimateShGeometry(half, k, {}, options, &first);
  EXPECT_FALSE(other.depth_filtered);
  EXPECT_TRUE(other.depth_noise.has_value());

  ShGeometryOptions never = options;  // no filtering, nothing measured
  never.filter_depth = false;
  const ShGeometry unmeasured = EstimateShGeometry(noisy, scene.intrinsics, {}, never, nullptr);
  EXPECT_FALSE(unmeasured.depth_filtered);
  EXPECT_FALSE(unmeasured.depth_noise.has_value());
  ShGeometryOptions always = options;  // filtered whatever the noise, nothing measured
  always.skip_filter_below_at_1m_m = 0.0;
  const ShGeometry forced = EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, always, nullptr);
  EXPECT_TRUE(forced.depth_filtered);
  EXPECT_FALSE(forced.depth_noise.has_value());
  ShGeometryOptions bad = options;
  bad.skip_filter_below_at_1m_m = -1.0;
  EXPECT_THROW(EstimateShGeometry(frame.depth_m, scene.intrinsics, {}, bad, nullptr), InvalidArgumentError);
}

// The same surface in two frames: depth in both, moved by at most `sigmas` range sigmas (which
// grow as z^2); the changed fraction counts the rest of the pixels with depth in either.
TEST(ShPipelineTest, UnchangedDepthMaskKeepsTheSameSurfaceOnly) {
  cv::Mat a(2, 3, CV_32FC1, cv::Scalar(2.0f)), b = a.clone();
  b.at<float>(0, 0) = 2.0f + 0.05f;                                                 // within 3 x 0.005 x 2^2 = 0.06 m
  b.at<float>(0, 1) = 2.0f + 0.07f;                                                 // beyond 0.06 m
  b.at<float>(0, 2) = std::numeric_limits<float>::quiet_NaN();                      // vanished
  a.at<float>(1, 0) = 0.0f;                                                         // no depth in a
  a.at<float>(1, 1) = b.at<float>(1, 1) = std::numeric_limits<float>::quiet_NaN();  // in neither
  const cv::Mat same = UnchangedDepthMask(a, b, 0.005, 3.0);
  EXPECT_EQ(same.type(), CV_8UC1);
  EXPECT_EQ(same.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(same.at<std::uint8_t>(0, 1), 0);
  EXPECT_EQ(same.at<std::uint8_t>(0, 2), 0);
  EXPECT_EQ(same.at<std::uint8_t>(1, 0), 0);
  EXPECT_EQ(same.at<std::uint8_t>(1, 1), 0);
  EXPECT_EQ(same.at<std::uint8_t>(1, 2), 255);
  EXPECT_EQ(cv::countNonZero(same), 2);
  EXPECT_DOUBLE_EQ(ChangedDepthFraction(a, b, 0.005, 3.0), 3.0 / 5.0);  // 5 pixels with depth in either
}

// max over the object of |E_a(n) / E_b(n) - E_c(n) / E_d(n)| / (E_c(n) / E_d(n)) per channel, at
// the true normals: how far a fitted light ratio (a / b) is from the true one (c / d).
double WorstRatioError(const testing::SyntheticFrame& frame, const ShRgb& a, const ShRgb& b, const ShRgb& c,
                       const ShRgb& d) {
  double worst = 0.0;
  for (int y = 0; y < frame.object_mask.rows; y += 2) {
    for (int x = 0; x < frame.object_mask.cols; x += 2) {
      if (!frame.object_mask.at<std::uint8_t>(y, x)) continue;
      const cv::Vec3f v = frame.normal_in_camera.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d n(v[0], v[1], v[2]);
      const Eigen::Vector3d fitted = ShIrradiance(a, n).cwiseQuotient(ShIrradiance(b, n));
      const Eigen::Vector3d truth = ShIrradiance(c, n).cwiseQuotient(ShIrradiance(d, n));
      worst = std::max(worst, (fitted - truth).cwiseQuotient(truth).cwiseAbs().maxCoeff());
    }
  }
  return worst;
}

TEST(ShPipelineTest, SharedAlbedoTakesTheReferencesSegmentsAndAlbedosAsKnown) {
  const testing::SceneOptions scene;
  const ShRgb src_light = SkyLight();
  testing::SkySunOptions low;
  low.sun_dir_in_map = Eigen::Vector3d(-0.8, 0.3, 0.35).normalized();
  ShRgb dst_light = ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, low), testing::CameraFromMap());
  dst_light.col(0) *= 1.4;  // a warmer light: the chromaticities move
  dst_light.col(2) *= 0.7;
  const testing::SyntheticFrame src = testing::RenderScene(scene, src_light);
  const testing::SyntheticFrame dst = testing::RenderScene(scene, dst_light);
  SegmentationOptions segmentation;
  segmentation.segment_count = 3;

  // A reference whose albedos are the truth times a per-channel scale: the shared fit finds the
  // destination light divided by that scale, from either way of labelling.
  ShFrameFit reference;
  reference.segmentation = SegmentByColor(src.radiance, src.object_mask, {}, segmentation);
  ASSERT_EQ(reference.segmentation.segment_count(), 3);
  const Eigen::Vector3d scale(2.0, 1.0, 0.5);
  for (int l = 0; l < 3; ++l) {
    const cv::Scalar mean = cv::mean(src.albedo, SegmentMask(reference.segmentation, l));
    reference.segment_albedo.push_back(Eigen::Vector3d(mean[0], mean[1], mean[2]).cwiseProduct(scale));
  }
  reference.reference_segment = 0;
  ShRgb scaled = dst_light;
  for (int c = 0; c < 3; ++c) scaled.col(c) /= scale[c];
  for (const bool same_surface : {true, false}) {
    SamplePointSelector selector;
    const ShFrameFit fit =
        FitShFrameSharedAlbedo(dst.radiance, dst.normal_in_camera, dst.object_mask, reference,
                               same_surface ? dst.object_mask : cv::Mat(), segmentation, {}, selector);
    ASSERT_TRUE(fit.summary.usable) << fit.summary.message;
    EXPECT_EQ(fit.segment_albedo, reference.segment_albedo);
    EXPECT_EQ(fit.reference_segment, 0);
    EXPECT_EQ(fit.samples.size(), 2000u);
    EXPECT_LT(WorstRatioError(dst, fit.light, src_light, scaled, src_light), same_surface ? 1e-4 : 1e-3)
        << same_surface;
  }

  // From an unknown-albedo fit of the source: the ratio of the lights is the true one, whatever
  // scale the unknown albedos took.
  SamplePointSelector src_samples, dst_samples;
  ShAlbedoFitOptions unknown;
  const ShFrameFit own =
      FitShFrameUnknownAlbedo(src.radiance, src.normal_in_camera, src.object_mask, segmentation, unknown, src_samples);
  ASSERT_TRUE(own.summary.usable);
  const ShFrameFit shared = FitShFrameSharedAlbedo(dst.radiance, dst.normal_in_camera, dst.object_mask, own,
                                                   dst.object_mask, segmentation, {}, dst_samples);
  ASSERT_TRUE(shared.summary.usable);
  EXPECT_LT(WorstRatioError(dst, shared.light, own.light, dst_light, src_light), 1e-3);

  // Made absolute by one segment's true albedo: the light and every albedo are the truth.
  ShFrameFit absolute = own;
  const int big = own.segmentation.labels.at<int>(120, 160);
  ASSERT_GE(big, 0);
  ASSERT_EQ(src.object_id.at<int>(120, 160), testing::kBigSphere);
  SetSegmentAlbedo(big, scene.big_sphere_albedo, &absolute);
  EXPECT_EQ(absolute.reference_segment, big);
  ShRgb unit = ShRgb::Zero();
  unit(0, 0) = unit(0, 1) = unit(0, 2) = 1.0;  // E(n) = const: the ratio is E itself
  EXPECT_LT(WorstRatioError(src, absolute.light, unit, src_light, unit), 1e-3);
  for (int l = 0; l < own.segmentation.segment_count(); ++l) {
    const cv::Scalar mean = cv::mean(src.albedo, SegmentMask(own.segmentation, l));
    EXPECT_LT((absolute.segment_albedo[static_cast<std::size_t>(l)] - Eigen::Vector3d(mean[0], mean[1], mean[2]))
                  .cwiseAbs()
                  .maxCoeff(),
              1e-3)
        << l;
  }
  EXPECT_THROW(SetSegmentAlbedo(7, scene.big_sphere_albedo, &absolute), InvalidArgumentError);
  EXPECT_THROW(SetSegmentAlbedo(big, Eigen::Vector3d(0.5, 0.0, 0.5), &absolute), InvalidArgumentError);

  // A reference that is not an unknown-albedo fit is refused.
  ShFrameFit known;
  known.segmentation = reference.segmentation;
  SamplePointSelector selector;
  EXPECT_THROW(FitShFrameSharedAlbedo(dst.radiance, dst.normal_in_camera, dst.object_mask, known, {}, segmentation, {},
                                      selector),
               InvalidArgumentError);
}

TEST(ShPipelineTest, RejectsMismatchedIntrinsics) {
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, SkyLight());
  ShLightEstimator estimator;
  const PinholeIntrinsics wrong = PinholeIntrinsics::FromHorizontalFov(640, 480, 1.0);
  EXPECT_THROW(estimator.EstimateUnknownAlbedo(frame.radiance, frame.depth_m, wrong, frame.object_mask),
               InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
