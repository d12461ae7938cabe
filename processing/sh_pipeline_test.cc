#include "processing/sh_pipeline.h"

#include <gtest/gtest.h>

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
