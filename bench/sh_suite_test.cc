// The SH random-scene suites at quick sizes (160x120), 12 seeded scenes each. The bounds are
// the suites' measured figures (seed 1, 2026-12-05; lamp-lit ones 2026-12-07) with a small margin: they catch a
// regression of the method or of the suite's truth, and they state where SH stands against
// issue 20's goals (2 % / 3 % ideal depth, 4 % / 6 % Kinect noise), which it does not meet:
// see docs/benchmarks.md, "Random-scene suites: SH", for why.
#include <gtest/gtest.h>

#include "bench/suites.h"

namespace relume::bench {
namespace {

SuiteResult RunQuick(std::vector<SuiteResult> (*run)(const SuiteOptions&)) {
  SuiteOptions options;
  options.scenes = 12;
  options.seed = 1;
  options.quick = true;
  SuiteResult r = run(options).at(0);
  r.Summarize();
  return r;
}

TEST(ShSuiteTest, LampLitScenesSitAboveTheOrderTwoFloor) {
  const SuiteResult r = RunQuick(RunShIdealDepthSuite);
  ASSERT_EQ(r.method_errors.failed, 0);
  ASSERT_EQ(r.floor_errors.failed, 0);
  // Measured: method median 9.85 %, p90 32.7 %; floor (true normals, each pixel by its own
  // ratio) 9.70 %, 27.3 %. (With the relighting guard at 0.05: 10.4 %, 33.2 %; floor 10.4 %,
  // 31.5 %. Before the relighting ratio was filtered: 12.0 %, 44.0 %; before normals were
  // refined beside creases: 15.6 %, 56.7 %.)
  EXPECT_LT(r.method_errors.median, 0.115);
  EXPECT_LT(r.method_errors.p90, 0.38);
  // The floor is order-2 SH itself: a lamp's clamped cosine is not band-limited, so even true
  // normals leave about 10 %. It must not drop to zero (that would mean the truth became
  // band-limited, and the suite no longer tests lamp-lit scenes).
  EXPECT_GT(r.floor_errors.median, 0.05);
  EXPECT_LT(r.floor_errors.median, 0.12);
  // The ratio filter also averages some of the model's own error, so the method may meet the
  // floor; it must stay near it.
  EXPECT_LT(r.method_errors.median, r.floor_errors.median + 0.02);
}

TEST(ShSuiteTest, KinectNoiseCostsLittleAboveExactDepth) {
  const SuiteResult r = RunQuick(RunShKinectNoiseSuite);
  ASSERT_EQ(r.method_errors.failed, 0);
  // Measured: median 14.7 %, p90 39.8 %; floor 9.87 %, 30.1 %. The relighting ratio's filter is
  // wider for normals from noisy depth (RelightOptions::noisy_ratio_*: radius 6 px); before
  // (radius 3): 14.1 %, 43.7 %; at 320x240 it gains more (60 scenes: median 15.4 -> 12.7 %),
  // as the radius is in pixels. Guard 0.05: 14.4 %, 50.6 %; before the ratio was filtered:
  // 17.5 %, 65.9 %. Filtered depth gets no crease refinement (its 3 x 3 fits would follow the
  // noise).
  EXPECT_LT(r.method_errors.median, 0.16);
  EXPECT_LT(r.method_errors.p90, 0.44);
  EXPECT_LE(r.floor_errors.median, r.method_errors.median);
}

TEST(ShSuiteTest, SmoothLightsAreWithinTheModelAndNormalsAreTheGap) {
  const SuiteResult r = RunQuick(RunShSmoothLightSuite);
  ASSERT_EQ(r.method_errors.failed, 0);
  ASSERT_EQ(r.floor_errors.failed, 0);
  // Under smooth lights order-2 SH represents the irradiance: with true normals the relit
  // error is about 1 % (measured 1.07 %, p90 6.1 %). This also checks the suite's truth: a
  // wrong SH projection or irradiance table would show here.
  EXPECT_LT(r.floor_errors.median, 0.015);
  EXPECT_LT(r.floor_errors.p90, 0.07);
  // The method's normals from depth cost the rest (measured median 4.93 %, p90 8.46 %; before
  // the relighting ratio was filtered 8.16 %, 14.2 %; before normals were refined beside creases
  // 10.2 %, 27.7 %): silhouettes, and creases where three faces meet.
  EXPECT_LT(r.method_errors.median, 0.06);
  EXPECT_LT(r.method_errors.p90, 0.10);
}

TEST(ShSuiteTest, InterreflectionRaisesTheFloorAndTheMethodStaysNearIt) {
  // The smooth-light scenes with the light the objects and the wall send each other (3
  // bounces; 10-14 % of the objects' irradiance on the first scenes): near-field light that a
  // distant SH light cannot represent. Measured: method median 4.77 %, p90 8.36 %; floor
  // 2.08 %, 10.7 % (without the bounces 1.07 %, 6.1 %).
  const SuiteResult r = RunQuick(RunShSmoothLightBouncesSuite);
  ASSERT_EQ(r.method_errors.failed, 0);
  ASSERT_EQ(r.floor_errors.failed, 0);
  EXPECT_EQ(r.suite, "sh-smooth-light-bounces");
  EXPECT_NE(r.scenes.at(0).notes.find("indirect share"), std::string::npos) << r.scenes.at(0).notes;
  EXPECT_LT(r.method_errors.median, 0.055);
  EXPECT_LT(r.method_errors.p90, 0.10);
  const SuiteResult direct = RunQuick(RunShSmoothLightSuite);
  EXPECT_GT(r.floor_errors.median, direct.floor_errors.median + 0.005);
  EXPECT_LT(r.floor_errors.median, 0.03);
  // The same draws as the suite without bounces.
  for (std::size_t i = 0; i < r.scenes.size(); ++i) EXPECT_EQ(r.scenes[i].description, direct.scenes[i].description);
}

TEST(ShSuiteTest, ScenesRepeatFromTheirSeed) {
  SuiteOptions options;
  options.scenes = 2;
  options.seed = 5;
  options.quick = true;
  const SuiteResult a = RunShKinectNoiseSuite(options).at(0), b = RunShKinectNoiseSuite(options).at(0);
  ASSERT_EQ(a.scenes.size(), 2u);
  for (std::size_t i = 0; i < a.scenes.size(); ++i) {
    EXPECT_EQ(a.scenes[i].seed, b.scenes[i].seed);
    EXPECT_EQ(a.scenes[i].method, b.scenes[i].method);
    EXPECT_EQ(a.scenes[i].floor, b.scenes[i].floor);
    EXPECT_EQ(a.scenes[i].description, b.scenes[i].description);
  }
  EXPECT_NE(a.scenes[0].method, a.scenes[1].method);
  // A row of suite.csv alone: --scene-seed.
  SuiteOptions one = options;
  one.scene_seed = a.scenes[1].seed;
  const SuiteResult c = RunShKinectNoiseSuite(one).at(0);
  ASSERT_EQ(c.scenes.size(), 1u);
  EXPECT_EQ(c.scenes[0].method, a.scenes[1].method);
  EXPECT_EQ(c.scenes[0].description, a.scenes[1].description);
}

}  // namespace
}  // namespace relume::bench
