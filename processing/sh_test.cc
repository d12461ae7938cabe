#include "processing/sh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "core/error.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<Eigen::Vector3d> RandomDirections(int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < count; ++i) out.push_back(Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized());
  return out;
}

TEST(ShTest, IndexConvention) {
  EXPECT_EQ(ShIndex(0, 0), 0);
  EXPECT_EQ(ShIndex(1, -1), 1);
  EXPECT_EQ(ShIndex(1, 1), 3);
  EXPECT_EQ(ShIndex(2, -2), 4);
  EXPECT_EQ(ShIndex(2, 2), 8);
  EXPECT_EQ(ShCountForOrder(1), 4);
  EXPECT_DOUBLE_EQ(ShBandFactor(0), kPi);
  EXPECT_DOUBLE_EQ(ShBandFactor(1), 2.0 * kPi / 3.0);
  EXPECT_DOUBLE_EQ(ShBandFactor(2), kPi / 4.0);
}

TEST(ShTest, BasisIsOrthonormalOverTheSphere) {
  const int width = 512, height = 256;
  Eigen::Matrix<double, 9, 9> gram = Eigen::Matrix<double, 9, 9>::Zero();
  for (int v = 0; v < height; ++v) {
    const double solid_angle = LatLongPixelSolidAngle(v, width, height);
    for (int u = 0; u < width; ++u) {
      const ShVector y = ShBasis(LatLongDirection(u + 0.5, v + 0.5, width, height));
      gram += y * y.transpose() * solid_angle;
    }
  }
  EXPECT_LT((gram - Eigen::Matrix<double, 9, 9>::Identity()).cwiseAbs().maxCoeff(), 2e-4) << gram;
}

TEST(ShTest, PixelSolidAnglesSumToTheSphere) {
  double total = 0.0;
  for (int v = 0; v < 64; ++v) total += 128 * LatLongPixelSolidAngle(v, 128, 64);
  EXPECT_NEAR(total, 4.0 * kPi, 1e-12);
}

// A light linear in direction, L(w) = a + b (w . d), has the exact irradiance
// E(n) = a pi + b (2 pi / 3)(n . d): the clamped cosine's band factors A0 and A1.
TEST(ShTest, LinearLightHasAnalyticIrradiance) {
  const Eigen::Vector3d d = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const double a = 1.0, b = 0.7;
  ShRgb light = ShRgb::Zero();
  light.row(0).setConstant(a / 0.28209479177387814);  // a = L00 Y00
  // b (w . d) = sum_m L1m Y1m(w) with Y1m = 0.488603 (y, z, x).
  const double c = b / 0.4886025119029199;
  light.row(1).setConstant(c * d.y());
  light.row(2).setConstant(c * d.z());
  light.row(3).setConstant(c * d.x());
  for (const Eigen::Vector3d& n : RandomDirections(50, 3)) {
    const double expected = a * kPi + b * 2.0 * kPi / 3.0 * n.dot(d);
    EXPECT_NEAR(ShIrradiance(light, n)(1), expected, 1e-12);
    EXPECT_NEAR(ShRadiance(light, n)(0), a + b * n.dot(d), 1e-12);
  }
  EXPECT_NEAR(ShMeanIrradiance(light)(2), a * kPi, 1e-12);
}

TEST(ShTest, ProjectionOfALinearMapMatchesBruteForceIntegration) {
  const Eigen::Vector3d d = Eigen::Vector3d(-0.2, 0.4, 0.6).normalized();
  RadianceImage map = MakeRadianceImage(256, 128);
  for (int v = 0; v < 128; ++v) {
    for (int u = 0; u < 256; ++u) {
      const double value = 1.0 + 0.8 * LatLongDirection(u + 0.5, v + 0.5, 256, 128).dot(d);
      map.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f(value, 2 * value, 0.5 * value);
    }
  }
  const ShRgb light = ProjectEnvironmentMap(map, Eigen::Matrix3d::Identity());
  for (const Eigen::Vector3d& n : RandomDirections(20, 5)) {
    const double expected = kPi + 0.8 * 2.0 * kPi / 3.0 * n.dot(d);
    EXPECT_NEAR(ShIrradiance(light, n)(0), expected, 2e-3 * expected);
    EXPECT_NEAR(ShIrradiance(light, n)(1), 2 * expected, 4e-3 * expected);
    EXPECT_NEAR(IntegrateIrradiance(map, Eigen::Matrix3d::Identity(), n)(2), 0.5 * expected, 2e-3 * expected);
  }
}

// Ramamoorthi & Hanrahan: 9 coefficients reproduce the irradiance of natural lighting to
// about 1 % on average. Sky + a sun-like lobe, checked against direct summation.
TEST(ShTest, NineCoefficientIrradianceOfASkyWithSunIsWithinAFewPercent) {
  const RadianceImage map = testing::MakeSkySunMap(128, 64, {});
  const Eigen::Matrix3d rotation = testing::CameraFromMap();
  const ShRgb light = ProjectEnvironmentMap(map, rotation);
  double sum_rel = 0.0, max_rel = 0.0;
  const auto normals = RandomDirections(300, 11);
  for (const Eigen::Vector3d& n : normals) {
    const Eigen::Vector3d exact = IntegrateIrradiance(map, rotation, n);
    const Eigen::Vector3d approx = ShIrradiance(light, n);
    const double rel = (approx - exact).norm() / exact.norm();
    sum_rel += rel;
    max_rel = std::max(max_rel, rel);
  }
  const double mean_rel = sum_rel / normals.size();
  RecordProperty("mean_relative_error", std::to_string(mean_rel));
  RecordProperty("max_relative_error", std::to_string(max_rel));
  std::printf("SH-9 irradiance vs brute force (sky + sun lobe): mean %.4f, max %.4f\n", mean_rel, max_rel);
  EXPECT_LT(mean_rel, 0.02);
  EXPECT_LT(max_rel, 0.10);
}

TEST(ShTest, TruncationKeepsLowerBands) {
  ShRgb light = ShRgb::Random();
  const ShRgb first = TruncateSh(light, 1);
  EXPECT_EQ(first.topRows(4), light.topRows(4));
  EXPECT_TRUE(first.bottomRows(5).isZero());
  EXPECT_TRUE(TruncateSh(light, 0).bottomRows(8).isZero());
}

TEST(ShTest, EnvironmentMapWithNanOrWrongTypeIsRejected) {
  RadianceImage map = MakeRadianceImage(8, 4);
  map.pixels.at<cv::Vec3f>(1, 1)[0] = NAN;
  EXPECT_THROW(ProjectEnvironmentMap(map, Eigen::Matrix3d::Identity()), InvalidArgumentError);
  RadianceImage mono;
  mono.pixels = cv::Mat::zeros(4, 8, CV_32FC1);
  EXPECT_THROW(IntegrateIrradiance(mono, Eigen::Matrix3d::Identity(), Eigen::Vector3d::UnitZ()), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
