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

// The fraction of the labelled pixels of `s` whose label is the one `reference` has there.
double SameLabelShare(const Segmentation& s, const Segmentation& reference) {
  int labelled = 0, same = 0;
  for (int y = 0; y < s.labels.rows; ++y) {
    for (int x = 0; x < s.labels.cols; ++x) {
      const int l = s.labels.at<int>(y, x);
      if (l < 0) continue;
      ++labelled;
      same += l == reference.labels.at<int>(y, x);
    }
  }
  return labelled == 0 ? 0.0 : static_cast<double>(same) / labelled;
}

TEST(SegmentationTest, AnotherFrameIsLabelledWithTheReferencesSegments) {
  const testing::SyntheticFrame frame = testing::RenderScene({}, SomeLight());
  SegmentationOptions options;
  options.segment_count = 3;
  const Segmentation reference = SegmentByColor(frame.radiance, frame.object_mask, {}, options);
  ASSERT_EQ(reference.segment_count(), 3);
  ASSERT_EQ(reference.centres.rows, 3);
  ASSERT_EQ(reference.spread.size(), 3u);
  for (const float spread : reference.spread) {  // the sky's and the sun's colours: 0.010-0.024
    EXPECT_GT(spread, 0.0f);
    EXPECT_LT(spread, 0.05f);
  }
  const int usable = reference.pixel_count[0] + reference.pixel_count[1] + reference.pixel_count[2];

  // The same view under a light of another colour (x1.5 red, x0.6 blue): the chromaticities
  // move, so labelling without the colour balance loses pixels; with it, every pixel keeps its
  // material.
  ShRgb warm = SomeLight();
  warm.col(0) *= 1.5;
  warm.col(2) *= 0.6;
  const testing::SyntheticFrame other = testing::RenderScene({}, warm);
  const Segmentation balanced = LabelByCentres(reference, other.radiance, other.object_mask, {}, options);
  ASSERT_EQ(balanced.segment_count(), 3);
  EXPECT_GT(balanced.pixel_count[0] + balanced.pixel_count[1] + balanced.pixel_count[2], 0.99 * usable);
  EXPECT_GT(SameLabelShare(balanced, reference), 0.999);
  LabelByCentresOptions unbalanced;
  unbalanced.balance_colour = false;
  const Segmentation raw = LabelByCentres(reference, other.radiance, other.object_mask, {}, options, unbalanced);
  EXPECT_LT(raw.pixel_count[0] + raw.pixel_count[1] + raw.pixel_count[2], 0.5 * usable);

  // A material the reference frame did not show (red stripes on the big sphere) is left out...
  testing::SyntheticFrame patched = testing::RenderScene({}, SomeLight());
  int patch = 0;
  for (int y = 0; y < patched.object_id.rows; ++y) {
    for (int x = 0; x < patched.object_id.cols; ++x) {
      if (patched.object_id.at<int>(y, x) != testing::kBigSphere || x % 8 >= 4) continue;
      cv::Vec3f& c = patched.radiance.pixels.at<cv::Vec3f>(y, x);
      const float sum = c[0] + c[1] + c[2];
      c = cv::Vec3f(0.9f * sum, 0.05f * sum, 0.05f * sum);
      ++patch;
    }
  }
  ASSERT_GT(patch, 1000);
  LabelByCentresOptions fixed;
  fixed.balance_colour = false;  // the patch moves the mean colour; the light did not change
  const Segmentation left_out = LabelByCentres(reference, patched.radiance, patched.object_mask, {}, options, fixed);
  const int labelled = left_out.pixel_count[0] + left_out.pixel_count[1] + left_out.pixel_count[2];
  EXPECT_NEAR(labelled, usable - patch, 0.01 * usable);
  EXPECT_GT(SameLabelShare(left_out, reference), 0.999);
  // ...unless the caller says those pixels show the surface the reference frame showed there.
  const Segmentation kept =
      LabelByCentres(reference, patched.radiance, patched.object_mask, {}, options, fixed, patched.object_mask);
  EXPECT_EQ(kept.pixel_count, reference.pixel_count);
  EXPECT_EQ(SameLabelShare(kept, reference), 1.0);

  // Wrong inputs are refused with a reason.
  Segmentation without_centres;
  without_centres.pixel_count = {10};
  EXPECT_THROW(LabelByCentres(without_centres, other.radiance, other.object_mask, {}, options), InvalidArgumentError);
  EXPECT_THROW(
      LabelByCentres(reference, other.radiance, other.object_mask, {}, options, {}, cv::Mat::zeros(3, 3, CV_8UC1)),
      InvalidArgumentError);
  LabelByCentresOptions negative;
  negative.min_distance = -1.0;
  EXPECT_THROW(LabelByCentres(reference, other.radiance, other.object_mask, {}, options, negative),
               InvalidArgumentError);
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
