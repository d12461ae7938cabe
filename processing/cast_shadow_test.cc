#include "processing/cast_shadow.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace relume::processing {
namespace {

// A wall 2 m in front of the camera (facing it) and, optionally, a 0.2 m square card 1.5 m in
// front, both seen by a 200 x 200 camera with fx = 200. Lit by a distant light from d (toward
// the light, camera frame) of irradiance `e_d` and a uniform ambient radiance `ambient`.
struct Scene {
  PinholeIntrinsics k{200, 200, 200.0, 200.0, 100.0, 100.0};
  cv::Mat depth = cv::Mat(200, 200, CV_32FC1);
  cv::Mat normals = cv::Mat(200, 200, CV_32FC3, cv::Scalar(0.0f, 0.0f, -1.0f));
  cv::Mat mask = cv::Mat(200, 200, CV_8UC1, cv::Scalar(255));

  explicit Scene(bool card) {
    for (int v = 0; v < 200; ++v) {
      for (int u = 0; u < 200; ++u) {
        const Eigen::Vector3d ray = k.Unproject({u + 0.5, v + 0.5});
        const bool on_card = card && std::abs(ray.x() * 1.5) <= 0.1 && std::abs(ray.y() * 1.5) <= 0.1;
        depth.at<float>(v, u) = on_card ? 1.5f : 2.0f;
      }
    }
  }
};

ShRgb Light(const Eigen::Vector3d& d, double e_d, double ambient) {
  ShRgb light = ShRgb::Zero();
  const ShVector basis = ShBasis(d.normalized());
  for (int c = 0; c < 3; ++c) light.col(c) = e_d * basis;
  for (int c = 0; c < 3; ++c) light(0, c) += ambient * std::sqrt(4.0 * std::numbers::pi);
  return light;
}

TEST(CastShadowTest, FindsTheCardsShadowOnTheWall) {
  const Eigen::Vector3d d = Eigen::Vector3d(0.0, -0.6, -0.8);  // up and toward the camera
  const Scene scene(true);
  // Occluders are taken as thickness_m thick (the depth image shows only their front). With
  // 0.05 m the card is a slab from 1.5 to 1.55 m, whose shadow on the wall (moved along -d by
  // 0.5625-0.625 m) spans y 0.2375..0.475 m and x -0.1..0.1 m: 23.75 x 20 pixels; the ray's
  // 3 cm steps sample the slab twice, and those two slices cover 21-22 rows of it.
  CastShadowOptions thin;
  thin.thickness_m = 0.05;
  thin.depth_tolerance_m = thin.depth_tolerance_per_m = 0.0;
  const CastShadowEstimate e =
      EstimateCastShadows(scene.depth, scene.normals, scene.mask, scene.k, Light(d, 1.0, 0.05), thin);
  ASSERT_TRUE(e.marched);
  EXPECT_NEAR(e.light_direction.dot(d.normalized()), 1.0, 1e-9);
  EXPECT_NEAR(e.directional_irradiance, 1.0, 1e-9);
  EXPECT_EQ(e.facing_pixels, 200 * 200);
  EXPECT_NEAR(e.shadowed_pixels, 440, 40) << e.Describe();
  // There the model's irradiance is about E_d cos + pi ambient (the order-2 truncation moves it
  // a little): the removed share near 0.8 / (0.8 + 0.157) on the shadowed pixels.
  const double removed_at_shadow = 0.8 / (0.8 + std::numbers::pi * 0.05);
  EXPECT_NEAR(e.removed_share_rms, removed_at_shadow * std::sqrt(e.shadowed_pixels / 40000.0), 0.01) << e.Describe();
  // The default 0.5 m: a box from the card to the wall, whose shadow reaches the card's
  // silhouette (y 0.133..0.475 m visible: 34 x 20 pixels).
  const CastShadowEstimate box =
      EstimateCastShadows(scene.depth, scene.normals, scene.mask, scene.k, Light(d, 1.0, 0.05));
  EXPECT_NEAR(box.shadowed_pixels, 684, 50) << box.Describe();
}

TEST(CastShadowTest, NoOccluderOrADiffuseLightCastsNothing) {
  const Eigen::Vector3d d(0.0, -0.6, -0.8);
  const Scene wall(false);
  const CastShadowEstimate open = EstimateCastShadows(wall.depth, wall.normals, wall.mask, wall.k, Light(d, 1.0, 0.05));
  EXPECT_TRUE(open.marched);
  EXPECT_EQ(open.shadowed_pixels, 0);
  EXPECT_EQ(open.removed_share_rms, 0.0);
  const Scene card(true);
  const CastShadowEstimate diffuse =
      EstimateCastShadows(card.depth, card.normals, card.mask, card.k, Light(d, 0.001, 1.0));
  EXPECT_FALSE(diffuse.marched) << diffuse.Describe();
  EXPECT_LT(diffuse.directional_share, 0.05);
  // A light behind the wall: no pixel faces it.
  const CastShadowEstimate behind =
      EstimateCastShadows(card.depth, card.normals, card.mask, card.k, Light(Eigen::Vector3d(0, 0, 1), 1.0, 0.05));
  EXPECT_EQ(behind.facing_pixels, 0);
  EXPECT_EQ(behind.shadowed_pixels, 0);
}

TEST(CastShadowTest, RejectsMismatchedInputsAndBadOptions) {
  const Scene scene(true);
  const ShRgb light = Light(Eigen::Vector3d(0, -0.6, -0.8), 1.0, 0.05);
  EXPECT_THROW(EstimateCastShadows(scene.depth(cv::Rect(0, 0, 100, 100)), scene.normals, scene.mask, scene.k, light),
               InvalidArgumentError);
  CastShadowOptions bad;
  bad.steps = 0;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_THROW(EstimateCastShadows(scene.depth, scene.normals, scene.mask, scene.k, light, bad), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
