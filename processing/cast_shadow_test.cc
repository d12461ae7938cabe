#include "processing/cast_shadow.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

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

  // scale: every length times this (20: a wall 40 m away, a 4 m card 30 m away).
  explicit Scene(bool card, double scale = 1.0) {
    for (int v = 0; v < 200; ++v) {
      for (int u = 0; u < 200; ++u) {
        const Eigen::Vector3d ray = k.Unproject({u + 0.5, v + 0.5});
        const bool on_card = card && std::abs(ray.x() * 1.5) <= 0.1 && std::abs(ray.y() * 1.5) <= 0.1;
        depth.at<float>(v, u) = static_cast<float>(scale * (on_card ? 1.5 : 2.0));
      }
    }
  }

  // The scene's radiance (albedo 1, grey) under a distant light from d (camera frame) of
  // irradiance e_d and an ambient irradiance: the card's true (thin) shadow on the wall is where
  // the ray from the wall point toward d crosses the card's plane within the card.
  RadianceImage Render(const Eigen::Vector3d& d, double e_d, double ambient_irradiance, double scale = 1.0) const {
    const Eigen::Vector3d toward = d.normalized();
    RadianceImage image;
    image.pixels = cv::Mat(200, 200, CV_32FC3);
    for (int v = 0; v < 200; ++v) {
      for (int u = 0; u < 200; ++u) {
        const Eigen::Vector3d p = k.Unproject({u + 0.5, v + 0.5}) * depth.at<float>(v, u);
        bool shadowed = false;
        if (p.z() > 1.75 * scale && toward.z() < 0.0) {
          const Eigen::Vector3d at_card = p + toward * ((1.5 * scale - p.z()) / toward.z());
          shadowed = std::abs(at_card.x()) <= 0.1 * scale && std::abs(at_card.y()) <= 0.1 * scale;
        }
        const double cosine = std::max(0.0, -toward.z());  // every normal is (0, 0, -1)
        const double e = ambient_irradiance + (shadowed ? 0.0 : e_d * cosine);
        const float radiance = static_cast<float>(e / std::numbers::pi);
        image.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f(radiance, radiance, radiance);
      }
    }
    return image;
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
  thin.thickness_per_m = thin.max_distance_per_m = 0.0;  // fixed 1.5 m rays, 0.05 m occluders
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

TEST(CastShadowTest, ShadowsTowardAKnownSunAndWhetherItShone) {
  const Eigen::Vector3d d(0.0, -0.6, -0.8);
  const Scene scene(true);
  // Sunny: lit 0.8 + 0.1, shadowed 0.1 (irradiance). With the card taken 0.05 m thick (as in
  // the test above: 440 pixels, y 0.2375..0.475 m on the wall) the marched shadow is mostly the
  // true one (y 0.275..0.475 m, 420 pixels), so the shadowed side's median is the true shadow's
  // radiance: the contrast is exactly 9. (Thicker occluders mark more lit pixels shadowed and
  // dilute the contrast: the 0.5 m default marks y 0.133..0.46 m, half of it truly lit.)
  CastShadowOptions thin;
  thin.thickness_m = 0.05;
  thin.thickness_per_m = thin.max_distance_per_m = 0.0;
  thin.depth_tolerance_m = thin.depth_tolerance_per_m = 0.0;
  const DirectionalShadowEvidence sunny =
      EstimateShadowsToward(scene.depth, scene.normals, scene.mask, scene.k, d, scene.Render(d, 1.0, 0.1), thin);
  EXPECT_NEAR(sunny.direction.dot(d.normalized()), 1.0, 1e-12);
  EXPECT_EQ(sunny.facing_pixels, 200 * 200);
  EXPECT_NEAR(sunny.shadowed_pixels, 440, 40);
  EXPECT_NEAR(sunny.contrast, 9.0, 1e-5) << sunny.Describe();
  // Overcast (the same geometry, no direct light): the same pixels are marched as shadowed, but
  // the image shows no difference.
  const DirectionalShadowEvidence overcast =
      EstimateShadowsToward(scene.depth, scene.normals, scene.mask, scene.k, d, scene.Render(d, 0.0, 0.5), thin);
  EXPECT_EQ(overcast.shadowed_pixels, sunny.shadowed_pixels);
  EXPECT_NEAR(overcast.contrast, 1.0, 1e-6);
  // No occluder: no shadowed side, so no contrast.
  const Scene wall(false);
  const DirectionalShadowEvidence open =
      EstimateShadowsToward(wall.depth, wall.normals, wall.mask, wall.k, d, wall.Render(d, 1.0, 0.1));
  EXPECT_EQ(open.shadowed_pixels, 0);
  EXPECT_TRUE(std::isnan(open.contrast));
  // A light behind the wall: nothing faces it.
  const Eigen::Vector3d behind(0.0, 0.0, 1.0);
  EXPECT_EQ(EstimateShadowsToward(scene.depth, scene.normals, scene.mask, scene.k, behind, scene.Render(d, 1.0, 0.1))
                .facing_pixels,
            0);
  EXPECT_THROW(EstimateShadowsToward(scene.depth, scene.normals, scene.mask, scene.k, Eigen::Vector3d::Zero(),
                                     scene.Render(d, 1.0, 0.1)),
               InvalidArgumentError);
}

// The same card and wall 20 times larger (30 m and 40 m away: a building in front of another).
// Rays of a fixed 1.5 m, set for a table top, stop short of the card (12.5 m toward the light
// from the wall); rays as long as their point's depth (the default max_distance_per_m) reach it
// and find the shadow. Occluders 1 m thick (0.05 m scaled), as above.
TEST(CastShadowTest, RaysScaleWithTheScene) {
  const Eigen::Vector3d d(0.0, -0.6, -0.8);
  const double scale = 20.0;
  const Scene scene(true, scale);
  const RadianceImage sunny = scene.Render(d, 1.0, 0.1, scale);
  CastShadowOptions scaled;
  scaled.thickness_m = 0.05 * scale;
  scaled.thickness_per_m = 0.0;
  scaled.depth_tolerance_m = scaled.depth_tolerance_per_m = 0.0;
  CastShadowOptions table_top = scaled;
  table_top.max_distance_per_m = 0.0;
  EXPECT_EQ(EstimateShadowsToward(scene.depth, scene.normals, scene.mask, scene.k, d, sunny, table_top).shadowed_pixels,
            0);
  const DirectionalShadowEvidence found =
      EstimateShadowsToward(scene.depth, scene.normals, scene.mask, scene.k, d, sunny, scaled);
  EXPECT_NEAR(found.shadowed_pixels, 440, 40) << found.Describe();
  EXPECT_NEAR(found.contrast, 9.0, 1e-5) << found.Describe();
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
