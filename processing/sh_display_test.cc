#include "processing/sh_display.h"

#include <gtest/gtest.h>

#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

ShRgb SomeLight() {
  return ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, {}), testing::CameraFromMap());
}

TEST(ShDisplayTest, LatLongRoundTripsThroughProjection) {
  const ShRgb light = SomeLight();
  RadianceImage map;
  map.pixels = ShToLatLong(light, 256, 128, ShDisplayQuantity::kRadiance);
  const ShRgb back = ProjectEnvironmentMap(map, Eigen::Matrix3d::Identity());
  EXPECT_LT((back - light).norm(), 1e-3 * light.norm()) << back - light;
}

TEST(ShDisplayTest, LatLongHonoursTheMapRotation) {
  const ShRgb light = SomeLight();
  const Eigen::Matrix3d rotation = testing::CameraFromMap();
  const cv::Mat map = ShToLatLong(light, 64, 32, ShDisplayQuantity::kIrradiance, rotation);
  const Eigen::Vector3d w = rotation * LatLongDirection(10.5, 7.5, 64, 32);
  const Eigen::Vector3d expected = ShIrradiance(light, w);
  const cv::Vec3f got = map.at<cv::Vec3f>(7, 10);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected(c), 1e-5 * expected.norm());
}

TEST(ShDisplayTest, CubeCrossFacesAndEdges) {
  Eigen::Vector3d d;
  const int face = 8;
  ASSERT_TRUE(CubeCrossDirection(face + 4, face + 4, face, &d));  // front face, just off centre
  EXPECT_GT(d.z(), 0.95);
  ASSERT_TRUE(CubeCrossDirection(2 * face + 4, face + 4, face, &d));
  EXPECT_GT(d.x(), 0.95);  // right face
  ASSERT_TRUE(CubeCrossDirection(face + 4, 4, face, &d));
  EXPECT_LT(d.y(), -0.95);  // up face: -y in the camera frame
  EXPECT_FALSE(CubeCrossDirection(0, 0, face, &d));
  // Neighbouring pixels across the front/right seam point almost the same way.
  Eigen::Vector3d a, b;
  ASSERT_TRUE(CubeCrossDirection(2 * face - 1, face + 3, face, &a));
  ASSERT_TRUE(CubeCrossDirection(2 * face, face + 3, face, &b));
  EXPECT_LT((a - b).norm(), 2.5 / face);
  // Up/front seam.
  ASSERT_TRUE(CubeCrossDirection(face + 3, face - 1, face, &a));
  ASSERT_TRUE(CubeCrossDirection(face + 3, face, face, &b));
  EXPECT_LT((a - b).norm(), 2.5 / face);
}

TEST(ShDisplayTest, CubeCrossEvaluatesTheLightAndLeavesTheRestBlack) {
  const ShRgb light = SomeLight();
  const cv::Mat cube = ShToCubeCross(light, 16, ShDisplayQuantity::kRadiance);
  ASSERT_EQ(cube.rows, 48);
  ASSERT_EQ(cube.cols, 64);
  EXPECT_EQ(cube.at<cv::Vec3f>(2, 2), cv::Vec3f(0, 0, 0));
  Eigen::Vector3d w;
  ASSERT_TRUE(CubeCrossDirection(50, 20, 16, &w));
  const Eigen::Vector3d expected = ShRadiance(light, w);
  EXPECT_NEAR(cube.at<cv::Vec3f>(20, 50)[1], expected(1), 1e-5);
}

}  // namespace
}  // namespace relume::processing
