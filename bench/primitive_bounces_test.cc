#include "bench/primitive_bounces.h"

#include <gtest/gtest.h>

#include <numbers>

#include "core/error.h"

namespace relume::bench {
namespace {

namespace pt = processing::testing;

// A light whose irradiance differs per normal, so that a wrong hit normal shows.
Eigen::Vector3d Light(const Eigen::Vector3d& n) {
  return Eigen::Vector3d(2.0, 1.5, 1.0) * (1.5 + n.y() - 0.5 * n.z());
}

pt::PrimitiveScene WallOnly() {
  pt::PrimitiveScene scene;
  scene.wall_depth_m = 2.0;
  scene.wall_albedo = Eigen::Vector3d(0.6, 0.5, 0.4);
  return scene;
}

TEST(PrimitiveBouncesTest, APointFacingTheWallGetsTheWallsWholeRadiance) {
  // Every ray meets the wall, whose radiance is rho_w E(-z) / pi: E = pi L, exactly, and the
  // wall's rays toward the camera meet nothing, so more bounces add nothing.
  const pt::PrimitiveScene scene = WallOnly();
  const Eigen::Vector3d want = scene.wall_albedo.cwiseProduct(Light(Eigen::Vector3d(0, 0, -1)));
  for (int bounces : {1, 3}) {
    PrimitiveBouncesOptions options;
    options.bounces = bounces;
    options.paths = 16;
    const Eigen::Vector3d e =
        PrimitiveIndirectIrradiance(scene, Light, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 1), options, 7);
    EXPECT_LT((e - want).norm(), 1e-9 * want.norm()) << e.transpose();
  }
}

TEST(PrimitiveBouncesTest, APointPerpendicularToTheWallGetsHalf) {
  // Normal along +x: the half of the hemisphere toward +z meets the wall, half the cosine
  // weight. Stratified, 1024 paths: within half a per cent.
  const pt::PrimitiveScene scene = WallOnly();
  const Eigen::Vector3d want = 0.5 * scene.wall_albedo.cwiseProduct(Light(Eigen::Vector3d(0, 0, -1)));
  const Eigen::Vector3d e = PrimitiveIndirectIrradiance(scene, Light, Eigen::Vector3d(0, 0, 1),
                                                        Eigen::Vector3d(1, 0, 0), PrimitiveBouncesOptions{}, 3);
  EXPECT_NEAR(e(1) / want(1), 1.0, 0.005) << e.transpose();
}

TEST(PrimitiveBouncesTest, ASphereAheadSendsItsViewFactor) {
  // A sphere of radius r centred h along the normal covers a cosine-weighted share (r / h)^2
  // of the hemisphere. Uniform light: its radiance rho E / pi everywhere. No wall.
  pt::PrimitiveScene scene;
  scene.with_wall = false;
  pt::Primitive sphere;
  sphere.radius = 0.3;
  sphere.centre = Eigen::Vector3d(0, 0, 1.0);
  sphere.albedo = Eigen::Vector3d(0.8, 0.5, 0.2);
  scene.objects.push_back(sphere);
  const auto uniform = [](const Eigen::Vector3d&) { return Eigen::Vector3d(1.0, 1.0, 1.0); };
  // One point's estimate is quantised by the stratified grid (a cone of sin^2 = 0.09 holds 2 or 3
  // of its 32 rows); over the random shifts of many points it is unbiased.
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  constexpr int kPoints = 200;
  for (int i = 0; i < kPoints; ++i) {
    e += PrimitiveIndirectIrradiance(scene, uniform, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 1),
                                     PrimitiveBouncesOptions{}, static_cast<std::uint64_t>(i)) /
         kPoints;
  }
  const double share = 0.3 * 0.3;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(e(c) / (share * sphere.albedo(c)), 1.0, 0.01) << c << ": " << e.transpose();
}

TEST(PrimitiveBouncesTest, ABoxFaceAheadActsAsTheWallDoes) {
  // A turned box (90 deg about y) whose face at z = 2 covers nearly the whole hemisphere: the
  // face's outward normal is -z whichever of the box's axes it is.
  pt::PrimitiveScene scene;
  scene.with_wall = false;
  pt::Primitive box;
  box.kind = pt::Primitive::Kind::kBox;
  box.camera_from_box = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  box.half_extents = Eigen::Vector3d(1.0, 1e4, 1e4);  // box x is camera z after the turn
  box.centre = Eigen::Vector3d(0, 0, 3.0);
  box.albedo = Eigen::Vector3d(0.6, 0.5, 0.4);
  scene.objects.push_back(box);
  const Eigen::Vector3d want = box.albedo.cwiseProduct(Light(Eigen::Vector3d(0, 0, -1)));
  const Eigen::Vector3d e = PrimitiveIndirectIrradiance(scene, Light, Eigen::Vector3d(0, 0, 1),
                                                        Eigen::Vector3d(0, 0, 1), PrimitiveBouncesOptions{}, 5);
  EXPECT_NEAR(e(1) / want(1), 1.0, 1e-3) << e.transpose();
}

TEST(PrimitiveBouncesTest, FramesGetTheirIndirectLightDeterministically) {
  pt::PrimitiveScene scene;
  scene.intrinsics = PinholeIntrinsics::FromHorizontalFov(40, 30, 1.0);
  scene.wall_depth_m = 1.4;
  pt::Primitive sphere;
  sphere.centre = Eigen::Vector3d(0, 0, 1.1);
  sphere.radius = 0.15;
  scene.objects.push_back(sphere);
  const pt::SyntheticFrame direct = pt::RenderPrimitives(scene, Light);
  PrimitiveBouncesOptions options;
  options.paths = 64;
  pt::SyntheticFrame a = direct, b = direct;
  a.radiance.pixels = direct.radiance.pixels.clone();
  a.irradiance = direct.irradiance.clone();
  b.radiance.pixels = direct.radiance.pixels.clone();
  b.irradiance = direct.irradiance.clone();
  options.threads = 1;
  const PrimitiveBouncesSummary sa = AddPrimitiveInterreflection(scene, Light, options, &a);
  options.threads = 2;
  AddPrimitiveInterreflection(scene, Light, options, &b);
  EXPECT_EQ(sa.pixels, cv::countNonZero(direct.object_mask));
  // The sphere faces the wall 0.3 m behind it only with its back; its rim sees some wall.
  EXPECT_GT(sa.indirect_share_mean, 0.0);
  EXPECT_LT(sa.indirect_share_mean, 0.2);
  EXPECT_EQ(cv::norm(a.radiance.pixels, b.radiance.pixels, cv::NORM_INF), 0.0);
  // Only object pixels change, and only upward.
  cv::Mat added = a.radiance.pixels - direct.radiance.pixels;
  double lo = 0.0;
  cv::minMaxLoc(added.reshape(1), &lo);
  EXPECT_GE(lo, 0.0);
  cv::Mat wall_pixels;
  cv::bitwise_not(direct.object_mask, wall_pixels);
  EXPECT_EQ(cv::norm(a.radiance.pixels, direct.radiance.pixels, cv::NORM_INF, wall_pixels), 0.0);
  options.paths = 0;
  EXPECT_THROW(AddPrimitiveInterreflection(scene, Light, options, &a), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::bench
