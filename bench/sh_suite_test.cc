// The SH random-scene suites at quick sizes (160x120), 12 seeded scenes each. The bounds are
// the suites' measured figures (seed 1, 2026-12-05; lamp-lit ones 2026-12-07) with a small margin: they catch a
// regression of the method or of the suite's truth, and they state where SH stands against
// issue 20's goals (2 % / 3 % ideal depth, 4 % / 6 % Kinect noise), which it does not meet:
// see docs/benchmarks.md, "Random-scene suites: SH", for why.
#include <gtest/gtest.h>

#include "bench/suites.h"

namespace relume::bench {
namespace {

// Each SH suite's four results on the same scenes: [0] the SH method, [1] the non-negative
// directional light ("-nonneg"), [2] the SH fit with the albedo unknown ("-unknown-albedo"),
// [3] the non-negative light with the albedo unknown ("-nonneg-unknown-albedo"). With the albedo
// unknown the destination frame's segment albedos are shared with the source (the sh pipeline's
// shared_albedo).
std::vector<SuiteResult> RunQuickAll(std::vector<SuiteResult> (*run)(const SuiteOptions&)) {
  SuiteOptions options;
  options.scenes = 12;
  options.seed = 1;
  options.quick = true;
  std::vector<SuiteResult> all = run(options);
  for (SuiteResult& r : all) r.Summarize();
  return all;
}

TEST(ShSuiteTest, LampLitScenesSitAboveTheOrderTwoFloor) {
  const std::vector<SuiteResult> all = RunQuickAll(RunShIdealDepthSuite);
  ASSERT_EQ(all.size(), 4u);
  const SuiteResult& r = all[0];
  ASSERT_EQ(r.method_errors.failed, 0);
  ASSERT_EQ(r.floor_errors.failed, 0);
  // Measured: method median 9.99 %, p90 31.5 %; floor (true normals, each pixel by its own
  // ratio) 9.69 %, 27.3 %. (Before the relighting's shading check, RelightOptions::
  // max_albedo_deviation: 9.85 %, 32.7 %.) (With the relighting guard at 0.05: 10.4 %, 33.2 %; floor 10.4 %,
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

  // The non-negative directional light follows the lamps' terminators: its floor (true
  // normals) is a seventh of order-2 SH's (measured median 1.35 %, p90 4.72 %), and from the
  // method's normals it relights at half SH's error (4.42 %, p90 9.81 %; before the jets at
  // silhouettes 5.14 %, 12.2 %; before the shading check 5.09 %, 19.2 %: box faces seen edge-on,
  // relit many times too bright): at 160x120 the normals from depth are most of what is left.
  const SuiteResult& nonneg = all[1];
  EXPECT_EQ(nonneg.suite, "sh-ideal-depth-nonneg");
  ASSERT_EQ(nonneg.method_errors.failed, 0);
  EXPECT_LT(nonneg.floor_errors.median, 0.02);
  EXPECT_LT(nonneg.floor_errors.p90, 0.06);
  EXPECT_LT(nonneg.method_errors.median, 0.055);
  EXPECT_LT(nonneg.method_errors.median, 0.6 * r.method_errors.median);
  EXPECT_LT(nonneg.method_errors.p90, 0.12);

  // With the albedo unknown (the sh pipeline's default) and the destination's segment albedos
  // shared with the source, not knowing the albedo costs little (measured median 9.97 %, p90
  // 24.0 %; the floor here is the known-albedo method). Each frame fitted on its own, as before
  // 2026-12-08, relit twice as far off (18.7 %, 32.7 %).
  const SuiteResult& unknown = all[2];
  EXPECT_EQ(unknown.suite, "sh-ideal-depth-unknown-albedo");
  ASSERT_EQ(unknown.method_errors.failed, 0);
  EXPECT_EQ(unknown.floor_errors.median, r.method_errors.median);
  EXPECT_LT(unknown.method_errors.median, r.method_errors.median + 0.01);
  EXPECT_LT(unknown.method_errors.p90, 0.28);
  // The same with the non-negative light (light_model=nonnegative): measured 4.62 %, p90 12.3 %.
  const SuiteResult& nonneg_unknown = all[3];
  EXPECT_EQ(nonneg_unknown.suite, "sh-ideal-depth-nonneg-unknown-albedo");
  ASSERT_EQ(nonneg_unknown.method_errors.failed, 0);
  EXPECT_EQ(nonneg_unknown.floor_errors.median, nonneg.method_errors.median);
  EXPECT_LT(nonneg_unknown.method_errors.median, 0.05);
  EXPECT_LT(nonneg_unknown.method_errors.p90, 0.14);
}

TEST(ShSuiteTest, KinectNoiseCostsLittleAboveExactDepth) {
  const std::vector<SuiteResult> all = RunQuickAll(RunShKinectNoiseSuite);
  const SuiteResult& r = all[0];
  ASSERT_EQ(r.method_errors.failed, 0);
  // Measured: median 14.8 %, p90 39.4 %; floor 9.85 %, 29.9 % (before the shading check 14.7 %,
  // 39.8 %). The relighting ratio's filter is
  // wider for normals from noisy depth (RelightOptions::noisy_ratio_*: radius 6 px); before
  // (radius 3): 14.1 %, 43.7 %; at 320x240 it gains more (60 scenes: median 15.4 -> 12.7 %),
  // as the radius is in pixels. Guard 0.05: 14.4 %, 50.6 %; before the ratio was filtered:
  // 17.5 %, 65.9 %. Filtered depth gets no crease refinement (its 3 x 3 fits would follow the
  // noise).
  EXPECT_LT(r.method_errors.median, 0.16);
  EXPECT_LT(r.method_errors.p90, 0.44);
  EXPECT_LE(r.floor_errors.median, r.method_errors.median);
  // The non-negative light: measured median 11.8 %, p90 22.8 % (before the normals beside
  // discontinuities came from the neighbours' boxes 12.7 %, 25.7 %; before the shading check
  // p90 37.5 %; floor 1.40 %, 4.72 %): the noisy normals are nearly all of its error.
  const SuiteResult& nonneg = all[1];
  EXPECT_LT(nonneg.method_errors.median, r.method_errors.median);
  EXPECT_LT(nonneg.method_errors.median, 0.14);
  EXPECT_LT(nonneg.method_errors.p90, 0.27);
  EXPECT_LT(nonneg.floor_errors.median, 0.02);
  // With the albedo unknown, shared: SH measured 14.1 %, p90 41.9 %; the non-negative light
  // 11.8 %, 22.4 %.
  EXPECT_LT(all[2].method_errors.median, r.method_errors.median + 0.01);
  EXPECT_LT(all[3].method_errors.median, 0.13);
  EXPECT_LT(all[3].method_errors.p90, 0.25);
}

// The smooth-light suite and, on the same draws, the same with interreflection: one test, so
// that the suite without bounces runs once (the comparison needs it; under the sanitizers each
// run takes about 80 s).
TEST(ShSuiteTest, SmoothLightsAreWithinTheModelAndInterreflectionRaisesTheFloor) {
  const std::vector<SuiteResult> all = RunQuickAll(RunShSmoothLightSuite);
  const SuiteResult& direct = all[0];
  ASSERT_EQ(direct.method_errors.failed, 0);
  ASSERT_EQ(direct.floor_errors.failed, 0);
  // Under smooth lights order-2 SH represents the irradiance: with true normals the relit
  // error is about 1 % (measured 1.07 %, p90 6.1 %). This also checks the suite's truth: a
  // wrong SH projection or irradiance table would show here.
  EXPECT_LT(direct.floor_errors.median, 0.015);
  EXPECT_LT(direct.floor_errors.p90, 0.07);
  // The method's normals from depth cost the rest (measured median 4.65 %, p90 8.46 %; before
  // the shading check 4.93 %, 8.46 %; before the relighting ratio was filtered 8.16 %, 14.2 %;
  // before normals were refined beside creases 10.2 %, 27.7 %): silhouettes, and creases where
  // three faces meet.
  EXPECT_LT(direct.method_errors.median, 0.06);
  EXPECT_LT(direct.method_errors.p90, 0.10);
  // The non-negative light represents these lights almost exactly with true normals (measured
  // median 0.08 %, p90 0.14 %) and relights from the method's normals at 2.96 %, p90 4.97 %
  // (before the jets at silhouettes 3.41 %, 6.24 %; before the shading check 4.15 %, 8.07 %).
  const SuiteResult& direct_nonneg = all[1];
  ASSERT_EQ(direct_nonneg.floor_errors.failed, 0);
  EXPECT_LT(direct_nonneg.floor_errors.median, 0.002);
  EXPECT_LT(direct_nonneg.floor_errors.p90, 0.004);
  EXPECT_LT(direct_nonneg.method_errors.median, direct.method_errors.median);
  EXPECT_LT(direct_nonneg.method_errors.p90, 0.06);
  // Unknown albedo, shared: SH measured median 4.18 %, p90 7.45 % (each frame on its own, before
  // 2026-12-08: 10.4 %, 93.2 %: k-means segments that mix objects absorb the light differently
  // in each frame); the non-negative light 3.27 %, 8.64 %.
  EXPECT_LT(all[2].method_errors.median, 0.05);
  EXPECT_LT(all[2].method_errors.p90, 0.09);
  EXPECT_LT(all[3].method_errors.median, 0.036);
  EXPECT_LT(all[3].method_errors.p90, 0.10);

  // With the light the objects and the wall send each other (3 bounces; 10-14 % of the
  // objects' irradiance on the first scenes): near-field light that a distant SH light cannot
  // represent. Measured: method median 4.79 %, p90 8.36 %; floor 2.08 %, 10.7 % (without the
  // bounces 1.07 %, 6.1 %).
  const std::vector<SuiteResult> bounced = RunQuickAll(RunShSmoothLightBouncesSuite);
  const SuiteResult& r = bounced[0];
  ASSERT_EQ(r.method_errors.failed, 0);
  ASSERT_EQ(r.floor_errors.failed, 0);
  EXPECT_EQ(r.suite, "sh-smooth-light-bounces");
  EXPECT_NE(r.scenes.at(0).notes.find("indirect share"), std::string::npos) << r.scenes.at(0).notes;
  EXPECT_LT(r.method_errors.median, 0.055);
  EXPECT_LT(r.method_errors.p90, 0.10);
  EXPECT_GT(r.floor_errors.median, direct.floor_errors.median + 0.005);
  EXPECT_LT(r.floor_errors.median, 0.03);
  // The same draws as the suite without bounces.
  ASSERT_EQ(r.scenes.size(), direct.scenes.size());
  for (std::size_t i = 0; i < r.scenes.size(); ++i) EXPECT_EQ(r.scenes[i].description, direct.scenes[i].description);
  // No distant light, non-negative or not, represents the near-field light: the non-negative
  // light's floor rises from 0.08 % to 1.10 % (p90 7.44 %); from the method's normals it
  // relights at 3.92 %, p90 6.27 % (measured; before the shading check 4.52 %, 6.27 %).
  const SuiteResult& nonneg = bounced[1];
  EXPECT_GT(nonneg.floor_errors.median, 0.005);
  EXPECT_LT(nonneg.method_errors.median, 0.05);
  EXPECT_LT(nonneg.method_errors.p90, 0.07);
  // Unknown albedo, shared, non-negative light: measured 3.48 %, p90 7.05 %.
  EXPECT_LT(bounced[3].method_errors.median, 0.04);
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
