#include "core/color.h"

#include <gtest/gtest.h>

namespace relume {
namespace {

TEST(ColorTest, RoundTrips) {
  const Lab lab(52.3, -12.5, 31.0);
  EXPECT_TRUE(LabFromXyz(XyzFromLab(lab, WhiteD50()), WhiteD50()).isApprox(lab, 1e-12));
  const Lab dark(3.0, 1.0, -2.0);  // the linear segment near black
  EXPECT_TRUE(LabFromXyz(XyzFromLab(dark, WhiteD50()), WhiteD50()).isApprox(dark, 1e-10));
  const LinearRgb rgb(0.2, 0.5, 0.05);
  EXPECT_TRUE(LinearRgbFromLabD50(LabD50FromLinearRgb(rgb)).isApprox(rgb, 1e-9));
  for (double v : {0.0, 0.001, 0.2, 1.0}) EXPECT_NEAR(SrgbDecode(SrgbEncode(v)), v, 1e-12);
}

TEST(ColorTest, WhitesMapToWhites) {
  // D50 white adapted to D65 is D65 white; D65 white is linear RGB (1, 1, 1).
  EXPECT_TRUE(AdaptXyz(WhiteD50(), WhiteD50(), WhiteD65()).isApprox(WhiteD65(), 1e-12));
  EXPECT_TRUE(LinearRgbFromXyzD65(WhiteD65()).isApprox(LinearRgb(1, 1, 1), 1e-4));
  EXPECT_TRUE(LinearRgbFromLabD50(Lab(100, 0, 0)).isApprox(LinearRgb(1, 1, 1), 1e-4));
}

TEST(ColorTest, ShippedColorCheckerReference) {
  const ColorCheckerReference chart = LoadColorCheckerReference("config/colorchecker/xrite_classic_2014_lab_d50.yaml");
  ASSERT_EQ(chart.patches.size(), 24u);
  EXPECT_EQ(chart.patches[0].name, "dark skin");
  EXPECT_EQ(chart.patches[23].name, "black 2");
  // Neutral patches are nearly grey and get darker; every reflectance is within (0, 1).
  double previous = 2.0;
  for (int i : chart.NeutralIndices()) {
    const LinearRgb& rgb = chart.patches[static_cast<std::size_t>(i)].linear_rgb;
    EXPECT_LT(rgb.maxCoeff() - rgb.minCoeff(), 0.07 * rgb.mean() + 0.003)
        << chart.patches[static_cast<std::size_t>(i)].name;
    EXPECT_LT(rgb.mean(), previous);
    previous = rgb.mean();
  }
  for (const ColorCheckerPatch& p : chart.patches) {
    EXPECT_GT(p.linear_rgb.minCoeff(), -0.05) << p.name;  // cyan is just outside sRGB (R = -0.044)
    EXPECT_LT(p.linear_rgb.maxCoeff(), 1.0) << p.name;
  }
  EXPECT_NEAR(chart.patches[18].linear_rgb.mean(), 0.88, 0.03);  // white 9.5: ~88% reflectance
}

}  // namespace
}  // namespace relume
