#include "processing/irm/sky_shape.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/mesh.h"

namespace relume::irm {
namespace {

constexpr float kDeg = 3.14159265f / 180.0f;

// A ground plane and a camera 1.7 m above it looking north, pitched up by `pitch_deg`: the
// lower part of the picture is ground, the upper part sky from the horizon upward.
struct GroundView {
  TriangleMesh mesh = MakeQuad({-500, -500, 0}, {1000, 0, 0}, {0, 1000, 0}, 4);
  PinholeCamera camera;
  explicit GroundView(double pitch_deg, int width = 160, int height = 120, double hfov_deg = 70) {
    mesh.ComputeVertexNormals();
    const Eigen::Vector3d eye(0, 0, 1.7);
    const double p = pitch_deg * std::numbers::pi / 180.0;
    camera =
        PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(width, height, hfov_deg * std::numbers::pi / 180.0),
                              eye, eye + Eigen::Vector3d(0, std::cos(p), std::sin(p)), Eigen::Vector3d::UnitZ());
  }
  // Sky pixels L = a (1 + g z); ground pixels a constant grey.
  cv::Mat Render(const Eigen::Vector3f& a, const Eigen::Vector3f& g) const {
    cv::Mat image(camera.intrinsics.height, camera.intrinsics.width, CV_32FC3);
    const Eigen::Matrix3f rotation = camera.world_from_camera.linear().cast<float>();
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const Eigen::Vector3f d =
            (rotation * camera.intrinsics.Unproject({x + 0.5, y + 0.5}).cast<float>()).normalized();
        Eigen::Vector3f l = Eigen::Vector3f::Constant(3.0f);
        if (d.z() > 0.0f) l = a.cwiseProduct(Eigen::Vector3f::Ones() + g * d.z());
        image.at<cv::Vec3f>(y, x) = cv::Vec3f(l.x(), l.y(), l.z());
      }
    }
    return image;
  }
};

const Eigen::Vector3f kSunBehind = Eigen::Vector3f(0, -0.8f, 0.6f).normalized();  // south, behind the camera

TEST(SkyShapeTest, TheWorldsGradientSkyIsRecovered) {
  const GroundView s(20.0);
  const RayCaster caster(s.mesh);
  // The world's outdoor sky: horizon (34, 38, 44), zenith (18, 26, 42): g = Z / H - 1.
  const Eigen::Vector3f horizon(34, 38, 44), g(18.0f / 34 - 1, 26.0f / 38 - 1, 42.0f / 44 - 1);
  const SkyShape shape = FitSkyShape(caster, s.Render(horizon, g), s.camera, cv::Mat(), kSunBehind);
  ASSERT_TRUE(shape.measured) << shape.reason;
  EXPECT_LT((shape.gradient - g).cwiseAbs().maxCoeff(), 1e-3f) << shape.gradient.transpose();
  EXPECT_LT((shape.horizon - horizon).cwiseAbs().maxCoeff(), 1e-2f);
  EXPECT_GT(shape.pixels, 1000);
  EXPECT_NEAR(shape.min_elevation_rad, 0.0f, 2.0f * kDeg);
  EXPECT_GT(shape.max_elevation_rad, 40.0f * kDeg);
  EXPECT_LT(shape.rms_relative_residual, 1e-4);
}

TEST(SkyShapeTest, TheSunsAureoleCloudsAndMaskedPixelsDoNotBendIt) {
  const GroundView s(20.0);
  const RayCaster caster(s.mesh);
  const Eigen::Vector3f a(30, 35, 40), g(-0.4f, -0.3f, -0.1f);
  cv::Mat image = s.Render(a, g);
  // The sun in the picture, 30 deg up straight ahead, with a bright aureole around it.
  const Eigen::Vector3f sun = Eigen::Vector3f(0, std::cos(30 * kDeg), std::sin(30 * kDeg));
  const Eigen::Matrix3f rotation = s.camera.world_from_camera.linear().cast<float>();
  cv::Mat mask(image.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const Eigen::Vector3f d =
          (rotation * s.camera.intrinsics.Unproject({x + 0.5, y + 0.5}).cast<float>()).normalized();
      if (d.dot(sun) > std::cos(8 * kDeg)) image.at<cv::Vec3f>(y, x) *= 50.0f;
      if (x < 12 && d.z() > 0.2f) image.at<cv::Vec3f>(y, x) *= 3.0f;  // a cloud at the left edge
      if (x > 150 && y < 10) {  // saturated corner: masked, its values meaningless
        mask.at<std::uint8_t>(y, x) = 255;
        image.at<cv::Vec3f>(y, x) = cv::Vec3f(1e6f, 0.0f, NAN);
      }
    }
  }
  const SkyShape shape = FitSkyShape(caster, image, s.camera, mask, sun);
  ASSERT_TRUE(shape.measured) << shape.reason;
  EXPECT_LT((shape.gradient - g).cwiseAbs().maxCoeff(), 0.02f) << shape.gradient.transpose();
  // Without the sun's exclusion and the trimming, the same picture gives another sky.
  SkyShapeOptions naive;
  naive.sun_exclusion_rad = 0.0f;
  naive.trim_fraction = 0.0f;
  const SkyShape bent = FitSkyShape(caster, image, s.camera, mask, sun, naive);
  EXPECT_FALSE(bent.measured && (bent.gradient - g).cwiseAbs().maxCoeff() < 0.1f) << bent.gradient.transpose();
}

TEST(SkyShapeTest, TooLittleSkyOrElevationKeepsTheSkyUniformAndSaysWhy) {
  // Looking down at the ground: no sky at all.
  const GroundView down(-60.0);
  const RayCaster down_caster(down.mesh);
  const SkyShape none =
      FitSkyShape(down_caster, down.Render({30, 30, 30}, {-0.5f, -0.5f, -0.5f}), down.camera, cv::Mat(), kSunBehind);
  EXPECT_FALSE(none.measured);
  EXPECT_EQ(none.gradient, Eigen::Vector3f::Zero());
  EXPECT_NE(none.reason.find("too few sky pixels"), std::string::npos) << none.reason;
  // A telephoto view of the horizon: the sky spans about 1 deg of elevation.
  const GroundView narrow(-1.0, 160, 120, 4.0);
  const RayCaster narrow_caster(narrow.mesh);
  const SkyShape flat = FitSkyShape(narrow_caster, narrow.Render({30, 30, 30}, {-0.5f, -0.5f, -0.5f}), narrow.camera,
                                    cv::Mat(), kSunBehind);
  EXPECT_FALSE(flat.measured);
  EXPECT_NE(flat.reason.find("elevation"), std::string::npos) << flat.reason;
  // Wrong image types are errors, not guesses.
  EXPECT_THROW(FitSkyShape(narrow_caster, cv::Mat(120, 160, CV_8UC3), narrow.camera, cv::Mat(), kSunBehind),
               InvalidArgumentError);
  SkyShapeOptions bad;
  bad.min_pixels = 1;
  EXPECT_THROW(
      FitSkyShape(narrow_caster, narrow.Render({1, 1, 1}, {0, 0, 0}), narrow.camera, cv::Mat(), kSunBehind, bad),
      InvalidArgumentError);
}

}  // namespace
}  // namespace relume::irm
