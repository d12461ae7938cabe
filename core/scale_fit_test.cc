#include "core/scale_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace relume {
namespace {

TEST(ScaleFitTest, RecoversAKnownScaleAndItsResidual) {
  ScaleFitter fitter;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> value(0.1, 10.0);
  std::vector<std::pair<double, double>> pairs;
  for (int i = 0; i < 1000; ++i) {
    const double v = value(rng);
    const double r = 2.5 * v * (i % 2 == 0 ? 1.01 : 0.99);  // +-1 % about the scale
    pairs.emplace_back(v, r);
    fitter.Add(v, r);
  }
  const ScaleFit fit = fitter.Fit();
  ASSERT_TRUE(fit.usable) << fit.reason;
  EXPECT_EQ(fit.samples, 1000);
  // The closed form, summed directly.
  double vr = 0.0, vv = 0.0;
  for (const auto& [v, r] : pairs) {
    vr += v * r;
    vv += v * v;
  }
  EXPECT_NEAR(fit.scale, vr / vv, 1e-12 * fit.scale);
  EXPECT_NEAR(fit.scale, 2.5, 0.01);
  double sum = 0.0;
  for (const auto& [v, r] : pairs) sum += std::pow((fit.scale * v - r) / r, 2);
  EXPECT_NEAR(fit.relative_rms, std::sqrt(sum / 1000.0), 1e-9);
}

TEST(ScaleFitTest, NonFiniteAndNonPositivePairsAreIgnored) {
  ScaleFitter fitter;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const auto& [v, r] : std::vector<std::pair<double, double>>{
           {nan, 1.0}, {1.0, nan}, {inf, 1.0}, {0.0, 1.0}, {1.0, 0.0}, {-1.0, -2.0}}) {
    fitter.Add(v, r);
  }
  EXPECT_EQ(fitter.samples(), 0);
  const ScaleFit none = fitter.Fit();
  EXPECT_FALSE(none.usable);
  EXPECT_EQ(none.scale, 1.0);
  EXPECT_FALSE(none.reason.empty());
  fitter.Add(2.0, 3.0);
  EXPECT_TRUE(fitter.Fit().usable);
  EXPECT_DOUBLE_EQ(fitter.Fit().scale, 1.5);
  EXPECT_EQ(fitter.Fit().relative_rms, 0.0);
  // Too few pairs for the caller's minimum: not usable, scale 1, and the reason says so.
  const ScaleFit few = fitter.Fit(10);
  EXPECT_FALSE(few.usable);
  EXPECT_EQ(few.scale, 1.0);
  EXPECT_NE(few.reason.find("10"), std::string::npos) << few.reason;
}

}  // namespace
}  // namespace relume
