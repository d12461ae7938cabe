#include "processing/segmentation.h"

#include <gtest/gtest.h>

#include <map>
#include <set>

#include "core/error.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

ShRgb SomeLight() {
  return ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, {}), testing::CameraFromMap());
}

TEST(SegmentationTest, ChromaticityKMeansSeparatesTheThreeAlbedos) {
  const testing::SyntheticFrame frame = testing::RenderScene({}, SomeLight());
  SegmentationOptions options;
  options.segment_count = 3;
  const Segmentation segmentation = SegmentByColor(frame.radiance, frame.object_mask, {}, options);
  ASSERT_EQ(segmentation.segment_count(), 3);
  // Each label must be (almost) one object, and label 0 the largest: the big sphere.
  std::map<std::pair<int, int>, int> joint;
  for (int y = 0; y < frame.object_id.rows; ++y) {
    for (int x = 0; x < frame.object_id.cols; ++x) {
      const int label = segmentation.labels.at<int>(y, x);
      if (label >= 0) ++joint[{label, frame.object_id.at<int>(y, x)}];
    }
  }
  for (int label = 0; label < 3; ++label) {
    int best = 0;
    for (int id = 0; id < 3; ++id) best = std::max(best, joint[{label, id}]);
    EXPECT_GT(best, 0.99 * segmentation.pixel_count[label]) << label;
  }
  const int big_sphere_in_label0 = joint[{0, testing::kBigSphere}];
  EXPECT_GT(big_sphere_in_label0, 0.99 * segmentation.pixel_count[0]);
  EXPECT_GE(segmentation.pixel_count[0], segmentation.pixel_count[1]);
  EXPECT_GE(segmentation.pixel_count[1], segmentation.pixel_count[2]);
}

TEST(SegmentationTest, BlackAndMaskedPixelsAreUnlabelled) {
  RadianceImage image = MakeRadianceImage(4, 4);
  image.pixels.setTo(cv::Scalar(0.2, 0.1, 0.1));
  image.pixels.at<cv::Vec3f>(0, 0) = cv::Vec3f(0, 0, 0);
  image.pixels.at<cv::Vec3f>(0, 1) = cv::Vec3f(NAN, 0, 0);
  cv::Mat mask(4, 4, CV_8UC1, cv::Scalar(255));
  mask.at<unsigned char>(3, 3) = 0;
  SegmentationOptions options;
  options.segment_count = 2;
  const Segmentation s = SegmentByColor(image, mask, {}, options);
  EXPECT_EQ(s.labels.at<int>(0, 0), -1);
  EXPECT_EQ(s.labels.at<int>(0, 1), -1);
  EXPECT_EQ(s.labels.at<int>(3, 3), -1);
  int total = 0;
  for (int c : s.pixel_count) total += c;
  EXPECT_EQ(total, 13);
}

TEST(SegmentationTest, EmptyMaskGivesNoSegments) {
  const Segmentation s = SegmentByColor(MakeRadianceImage(4, 4), cv::Mat::zeros(4, 4, CV_8UC1), {}, {});
  EXPECT_EQ(s.segment_count(), 0);
}

TEST(SamplePointSelectorTest, KeepsPointsInsideAndReselectsThoseThatLeft) {
  SamplePointOptions options;
  options.count = 100;
  SamplePointSelector selector(options);
  cv::Mat region = cv::Mat::zeros(50, 50, CV_8UC1);
  region(cv::Rect(0, 0, 30, 50)).setTo(255);
  const std::vector<cv::Point> first = selector.Update(region);
  ASSERT_EQ(first.size(), 100u);
  EXPECT_EQ(selector.reselected_count(), 100);
  // The region shrinks to x < 15: points with x >= 15 leave and are replaced.
  int staying = 0;
  for (const cv::Point& p : first) staying += p.x < 15;
  region(cv::Rect(15, 0, 15, 50)).setTo(0);
  const std::vector<cv::Point> second = selector.Update(region);
  EXPECT_EQ(selector.kept_count(), staying);
  EXPECT_EQ(selector.reselected_count(), 100 - staying);
  std::set<std::pair<int, int>> unique;
  for (const cv::Point& p : second) {
    EXPECT_LT(p.x, 15);
    unique.insert({p.x, p.y});
  }
  EXPECT_EQ(unique.size(), 100u);  // no point drawn twice
  for (const cv::Point& p : first) {
    if (p.x < 15) {
      EXPECT_TRUE(unique.count({p.x, p.y})) << "a point that stayed inside was dropped";
    }
  }
}

TEST(SamplePointSelectorTest, SmallRegionGivesFewerPoints) {
  SamplePointSelector selector({.count = 50, .seed = 1});
  cv::Mat region = cv::Mat::zeros(10, 10, CV_8UC1);
  region(cv::Rect(0, 0, 3, 3)).setTo(255);
  EXPECT_EQ(selector.Update(region).size(), 9u);
  EXPECT_TRUE(selector.Update(cv::Mat::zeros(10, 10, CV_8UC1)).empty());
  EXPECT_THROW(selector.Update(cv::Mat::zeros(10, 10, CV_32FC1)), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
