#include "sim/world/sampling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace relume::sim {
namespace {

TEST(SamplingTest, DiskPatternIsInsideTheDiskAndBalanced) {
  for (int n : {1, 4, 16, 64}) {
    const auto points = StratifiedDiskPattern(n);
    ASSERT_EQ(static_cast<int>(points.size()), n);
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : points) {
      EXPECT_LE(p.norm(), 1.0);
      mean += p / n;
    }
    EXPECT_LT(mean.norm(), 1e-12) << n;
  }
  // Area-stratified: the fraction of points within radius 1/sqrt(2) is one half.
  const auto points = StratifiedDiskPattern(256);
  int inner = 0;
  for (const auto& p : points) inner += p.norm() < std::sqrt(0.5) ? 1 : 0;
  EXPECT_EQ(inner, 128);
}

TEST(SamplingTest, CosinePatternIntegratesCosineMoments) {
  // Mean of f over the pattern ~ (1 / pi) * integral f cos dw: f = 1 gives 1, f = cos gives 2/3.
  const auto directions = CosineHemispherePattern(1024);
  double mean_cos = 0.0;
  for (const auto& d : directions) {
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    EXPECT_GE(d.z(), 0.0);
    mean_cos += d.z() / 1024;
  }
  EXPECT_NEAR(mean_cos, 2.0 / 3.0, 1e-4);
}

TEST(SamplingTest, OrthonormalBasisNearThePoles) {
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0),
                                   Eigen::Vector3d(0.3, -0.4, -0.866).normalized()}) {
    Eigen::Vector3d t, b;
    OrthonormalBasis(n, &t, &b);
    EXPECT_NEAR(t.norm(), 1.0, 1e-12);
    EXPECT_NEAR(b.norm(), 1.0, 1e-12);
    EXPECT_NEAR(t.dot(n), 0.0, 1e-12);
    EXPECT_NEAR(b.dot(n), 0.0, 1e-12);
    EXPECT_NEAR(t.dot(b), 0.0, 1e-12);
  }
}

TEST(SamplingTest, Pcg32IsRepeatableAndUniform) {
  Pcg32 a(7, 3), b(7, 3), c(7, 4);
  double mean = 0.0;
  bool differs = false;
  for (int i = 0; i < 10000; ++i) {
    const double x = a.NextDouble();
    EXPECT_EQ(x, b.NextDouble());
    differs = differs || x != c.NextDouble();
    EXPECT_GE(x, 0.0);
    EXPECT_LT(x, 1.0);
    mean += x / 10000;
  }
  EXPECT_TRUE(differs);
  EXPECT_NEAR(mean, 0.5, 0.01);
}

}  // namespace
}  // namespace relume::sim
