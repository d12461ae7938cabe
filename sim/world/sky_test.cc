#include "sim/world/sky.h"

#include <gtest/gtest.h>

#include <numbers>

namespace relume::sim {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(SkyTest, RadianceIsZeroBelowTheHorizon) {
  const Sky sky = Sky::Gradient({10, 20, 30}, {40, 40, 40});
  EXPECT_EQ(sky.Radiance({0, 0.6, -0.8}).norm(), 0.0);
  EXPECT_LT((sky.Radiance({0, 0, 1}) - Eigen::Vector3d(10, 20, 30)).norm(), 1e-12);
  EXPECT_LT((sky.Radiance({1, 0, 0}) - Eigen::Vector3d(40, 40, 40)).norm(), 1e-12);
  EXPECT_TRUE(Sky::Black().IsBlack());
}

TEST(SkyTest, UniformSkyShCoefficientsAreAnalytic) {
  const double l = 7.0;
  const ShCoefficients sh = Sky::Uniform(Eigen::Vector3d::Constant(l)).ProjectSh();
  // c00 = L * Y00 * 2 pi; c10 = L * 0.488603 * pi (integral of z over the upper half); the
  // others vanish by symmetry, c20 too (integral of 3 z^2 - 1 over the upper half is 0).
  EXPECT_NEAR(sh[0].x(), l * 0.28209479177387814 * 2 * kPi, 1e-5 * l);
  EXPECT_NEAR(sh[2].x(), l * 0.4886025119029199 * kPi, 1e-5 * l);
  for (int k : {1, 3, 4, 5, 6, 7, 8}) EXPECT_NEAR(sh[static_cast<std::size_t>(k)].x(), 0.0, 1e-5 * l) << k;
  // Irradiance from the SH on an upward plane is exactly pi L.
  EXPECT_NEAR(IrradianceFromSh(sh, Eigen::Vector3d::UnitZ()).x(), kPi * l, 1e-4 * l);
}

TEST(SkyTest, GradientSkyShGivesTheAnalyticHorizontalIrradiance) {
  const Sky sky = Sky::Gradient({10, 20, 40}, {40, 40, 40});
  const ShCoefficients sh = sky.ProjectSh();
  // c00 = Y00 * (2 pi h + pi (z - h)).
  EXPECT_NEAR(sh[0].x(), 0.28209479177387814 * (2 * kPi * 40 + kPi * (10 - 40)), 1e-3);
  const Eigen::Vector3d e = IrradianceFromSh(sh, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d expected = sky.HorizontalIrradiance();
  // Order 2 captures a hemisphere-clipped linear sky's irradiance to within a few percent.
  EXPECT_LT(((e - expected).array() / expected.array()).abs().maxCoeff(), 0.03) << e.transpose();
}

TEST(SkyTest, ShBasisIsOrthonormal) {
  // Midpoint quadrature over the sphere of Y_i * Y_j.
  double gram[9][9] = {};
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const double theta = (i + 0.5) * kPi / n;
    for (int j = 0; j < 2 * n; ++j) {
      const double phi = (j + 0.5) * kPi / n;
      const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      const auto y = ShBasis(d);
      const double w = std::sin(theta) * (kPi / n) * (kPi / n);
      for (int a = 0; a < 9; ++a)
        for (int b = 0; b < 9; ++b) gram[a][b] += w * y[static_cast<std::size_t>(a)] * y[static_cast<std::size_t>(b)];
    }
  }
  for (int a = 0; a < 9; ++a)
    for (int b = 0; b < 9; ++b) EXPECT_NEAR(gram[a][b], a == b ? 1.0 : 0.0, 1e-4) << a << "," << b;
}

}  // namespace
}  // namespace relume::sim
