#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "calibration/testing/synthetic_bracket.h"

namespace relume::bench {
namespace {

namespace ct = calibration::testing;

// --- The random monotone response generator (calibration/testing RandomResponse) ---

TEST(RandomResponseTest, CurvesRunFromZeroToOneStrictlyIncreasingAndChannelsDiffer) {
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const ct::SyntheticResponse r = ct::RandomResponse(seed);
    ASSERT_EQ(r.shape, ct::ResponseShape::kRandom);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(r.Forward(c, 0.0), 0.0, 1e-12) << "seed " << seed;
      EXPECT_NEAR(r.Forward(c, 1.0), 1.0, 1e-12) << "seed " << seed;
      double previous = r.Forward(c, 0.0);
      for (int i = 1; i <= 4096; ++i) {
        const double y = r.Forward(c, i / 4096.0);
        ASSERT_GT(y, previous) << "seed " << seed << " channel " << c << " x " << i / 4096.0;
        previous = y;
      }
      for (const double x : {0.001, 0.05, 0.3, 0.9}) {
        EXPECT_NEAR(r.Inverse(c, r.Forward(c, x)), x, 1e-9) << "seed " << seed;
      }
    }
    double apart = 0.0;
    for (int i = 1; i < 100; ++i) apart = std::max(apart, std::abs(r.Forward(0, i / 100.0) - r.Forward(1, i / 100.0)));
    EXPECT_GT(apart, 1e-3) << "seed " << seed << ": channels 0 and 1 are the same curve";
    std::string why;
    EXPECT_TRUE(ct::TrueInverseResponse(r).IsValid(&why)) << why;
  }
}

TEST(RandomResponseTest, IsReproducibleAndDrawsEveryFamily) {
  const ct::SyntheticResponse a = ct::RandomResponse(42), b = ct::RandomResponse(42), c = ct::RandomResponse(43);
  for (int i = 0; i <= 10; ++i) EXPECT_EQ(a.Forward(1, i / 10.0), b.Forward(1, i / 10.0));
  EXPECT_NE(a.Forward(1, 0.2), c.Forward(1, 0.2));
  EXPECT_EQ(ct::DescribeResponse(a), ct::DescribeResponse(b));
  std::set<std::string> families;
  int mixed = 0, contrast = 0, wiggled = 0;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const std::string d = ct::DescribeResponse(ct::RandomResponse(seed));
    for (const char* f : {"power", "srgb-like", "s-curve", "log"}) {
      if (d.find(std::string(" ") + f + " (") != std::string::npos) families.insert(f);
    }
    mixed += d.find(" + ") != std::string::npos;
    contrast += d.find("contrast 0.00,") == std::string::npos;
    wiggled += d.find("wiggle 0.00") == std::string::npos;
  }
  EXPECT_EQ(families.size(), 4u);
  // Drawn with probabilities 0.6, 0.5 and 0.7: all and none are both failures.
  EXPECT_GT(mixed, 15);
  EXPECT_LT(mixed, 55);
  EXPECT_GT(contrast, 10);
  EXPECT_LT(contrast, 55);
  EXPECT_GT(wiggled, 15);
  EXPECT_LT(wiggled, 58);
}

TEST(RandomResponseTest, ExistingShapesAreUnchanged) {
  const ct::SyntheticResponse gamma{ct::ResponseShape::kGamma};
  EXPECT_DOUBLE_EQ(gamma.Forward(2, 0.25), std::pow(0.25, 1.0 / 2.2));
  EXPECT_EQ(ct::DescribeResponse(gamma), "gamma");
  const ct::SyntheticResponse s{ct::ResponseShape::kSCurve};
  const double xm = std::pow(0.3, 1.7);
  EXPECT_DOUBLE_EQ(s.Forward(1, 0.5), std::pow(0.5, 1.7) / (std::pow(0.5, 1.7) + xm) * (1.0 + xm));
}

}  // namespace
}  // namespace relume::bench
