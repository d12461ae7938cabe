#include "core/pinhole.h"

#include <gtest/gtest.h>

namespace relume {
namespace {

TEST(PinholeTest, ProjectUnprojectRoundTrip) {
  const PinholeIntrinsics k = PinholeIntrinsics::FromHorizontalFov(640, 480, 1.0);
  std::string why;
  ASSERT_TRUE(k.IsValid(&why)) << why;
  const Eigen::Vector3d p(0.3, -0.2, 2.5);
  const Eigen::Vector2d uv = k.Project(p);
  EXPECT_TRUE((k.Unproject(uv) * p.z()).isApprox(p, 1e-12));
  // The optical axis passes through the centre of the image (between pixels 319 and 320).
  EXPECT_TRUE(k.Project(Eigen::Vector3d(0, 0, 1)).isApprox(Eigen::Vector2d(320, 240)));
  EXPECT_FALSE(PinholeIntrinsics{}.IsValid(&why));
}

TEST(PinholeTest, LookAtPointsTheOpticalAxisAtTheTarget) {
  const PinholeIntrinsics k = PinholeIntrinsics::FromHorizontalFov(100, 80, 1.2);
  const Eigen::Vector3d eye(10, -5, 2), target(0, 0, 1);
  const PinholeCamera camera = PinholeCamera::LookAt(k, eye, target);
  const Eigen::Vector3d target_in_camera = camera.world_from_camera.inverse() * target;
  EXPECT_NEAR(target_in_camera.x(), 0.0, 1e-12);
  EXPECT_NEAR(target_in_camera.y(), 0.0, 1e-12);
  EXPECT_GT(target_in_camera.z(), 0.0);
  // World up appears toward the top of the image (negative camera y).
  const Eigen::Vector3d above = camera.world_from_camera.inverse() * (target + Eigen::Vector3d::UnitZ());
  EXPECT_LT(above.y(), 0.0);
}

}  // namespace
}  // namespace relume
