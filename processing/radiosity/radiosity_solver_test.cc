#include "processing/radiosity/radiosity_solver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "processing/radiosity/direct_light.h"

namespace relume::radiosity {
namespace {

TEST(FormFactorTest, ParallelCoaxialSquaresMatchAnalytic) {
  // Point to a parallel unit-distance square of side 2 centred above: analytic
  // F = 4 * (1/(2 pi)) * (x / sqrt(1 + x^2) * atan(y / sqrt(1 + x^2)) + ...) for the corner
  // rectangle formula; here use the disc-free closed form for a rectangle a x b at height c
  // from a corner, summed over the four quadrants.
  const auto corner = [](double a, double b, double c) {
    const double x = a / c, y = b / c;
    return (x / std::sqrt(1 + x * x) * std::atan(y / std::sqrt(1 + x * x)) +
            y / std::sqrt(1 + y * y) * std::atan(x / std::sqrt(1 + y * y))) /
           (2.0 * std::numbers::pi);
  };
  const Eigen::Vector3d v[4] = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}};
  const double f =
      PointToPolygonFormFactor(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), v, 4, -Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(f, 4 * corner(1, 1, 1), 1e-12);
}

}  // namespace
}  // namespace relume::radiosity
