#include "bench/irm_suite.h"

#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "bench/suites.h"

namespace relume::bench {
namespace {

// The quick suite's errors on a fixed seed. Thresholds: a small margin above what was measured
// (the figures in the comments, 2026-12-02; the suite is deterministic).
constexpr int kScenes = 6;
constexpr std::uint64_t kSeed = 3;

// A suite's quick run on `scenes` scenes of kSeed, summarised.
std::vector<SuiteResult> RunQuick(std::vector<SuiteResult> (*run)(const SuiteOptions&), int scenes) {
  SuiteOptions options;
  options.scenes = scenes;
  options.seed = kSeed;
  options.quick = true;
  std::vector<SuiteResult> r = run(options);
  for (SuiteResult& s : r) s.Summarize();
  return r;
}

const std::vector<SuiteResult>& QuickSuite() {
  static const std::vector<SuiteResult> results = RunQuick(RunIrmSuite, kScenes);
  return results;
}

const SuiteResult& Region(const std::string& suite) {
  for (const SuiteResult& r : QuickSuite()) {
    if (r.suite == suite) return r;
  }
  ADD_FAILURE() << "no result " << suite;
  return QuickSuite().front();
}

TEST(IrmSuiteTest, ReturnsLitShadowAndPenumbraOverTheSameScenes) {
  const std::vector<SuiteResult>& results = QuickSuite();
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[0].suite, "irm-outdoor-lit");
  EXPECT_EQ(results[1].suite, "irm-outdoor-shadow");
  EXPECT_EQ(results[2].suite, "irm-outdoor-penumbra");
  for (const SuiteResult& r : results) {
    ASSERT_EQ(r.scenes.size(), static_cast<std::size_t>(kScenes));
    EXPECT_NE(r.metric.find("relative"), std::string::npos);
    for (int i = 0; i < kScenes; ++i) EXPECT_EQ(r.scenes[static_cast<std::size_t>(i)].seed, SceneSeed(kSeed, i));
  }
  EXPECT_DOUBLE_EQ(results[0].goal_median, 0.01);
  EXPECT_DOUBLE_EQ(results[1].goal_p90, 0.03);
  EXPECT_TRUE(std::isnan(results[2].goal_median));
}

TEST(IrmSuiteTest, LitAndShadowErrorsStayWithinWhatWasMeasured) {
  const SuiteResult& lit = Region("irm-outdoor-lit");
  const SuiteResult& shadow = Region("irm-outdoor-shadow");
  // Every scene has both regions (the generator redraws until the source view shows them).
  EXPECT_EQ(lit.method_errors.failed, 0);
  EXPECT_EQ(shadow.method_errors.failed, 0);
  // Measured (seed 3, 6 quick scenes): lit median 0.15 %, p90 0.23 %; shadow median 1.00 %,
  // p90 1.32 %. (Before the sky-view edges of 2026-12-02 the shadow floor alone was ~4 %.)
  EXPECT_LT(lit.method_errors.median, 0.0025);
  EXPECT_LT(lit.method_errors.p90, 0.0035);
  EXPECT_LT(shadow.method_errors.median, 0.012);
  EXPECT_LT(shadow.method_errors.p90, 0.016);
}

TEST(IrmSuiteTest, TheFloorIsAtOrBelowTheMethod) {
  for (const char* name : {"irm-outdoor-lit", "irm-outdoor-shadow"}) {
    const SuiteResult& r = Region(name);
    EXPECT_LE(r.floor_errors.median, r.method_errors.median) << name;
  }
}

TEST(IrmSuiteTest, TheSceneDependsOnTheSeedNotTheImageSize) {
  // Tiny renders: only the draw is compared (boxes, lights, cameras, redraws, the check).
  const IrmSuiteSize tiny{40, 28, 4, 16}, other{64, 45, 4, 16};
  for (int i = 0; i < 3; ++i) {
    const IrmSuiteScene a(SceneSeed(kSeed, i), tiny), b(SceneSeed(kSeed, i), other);
    EXPECT_EQ(a.Describe(), b.Describe());
    EXPECT_TRUE(a.accepted) << a.Describe();
    EXPECT_LE(a.redraws, IrmSuiteScene::kMaxRedraws);
    EXPECT_GE(a.boxes.size(), 1u);
    EXPECT_LE(a.boxes.size(), 5u);
    EXPECT_GE(a.boxes[0].height, 10.0f);  // the tall one that shadows the others
    EXPECT_GE(a.check_lit, 0.03);
    EXPECT_GE(a.check_shadow, 0.03);
    EXPECT_GE(a.check_overlap, 0.3);
    EXPECT_EQ(a.source.width(), 40);
    EXPECT_EQ(b.source.width(), 64);
  }
  EXPECT_NE(IrmSuiteScene(SceneSeed(kSeed, 0), tiny).Describe(), IrmSuiteScene(SceneSeed(kSeed, 1), tiny).Describe());
}

TEST(IrmSuiteTest, TheFloorsLightIsTheRenderersOwn) {
  // The floor's IrmSet reproduces E_target / E_source of the two lights for any normal, sun
  // fractions and sky view (the model's units: source sky K_s = 1).
  const IrmSuiteScene s(SceneSeed(kSeed, 0), IrmSuiteSize{40, 28, 4, 16});
  const irm::IrmSet set = TrueLightIrms(s.source_light.light, s.target_light.light, irm::RelightOptions{});
  const float pi = 3.14159265f;
  for (const Eigen::Vector3f& n : {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0.6f, -0.8f, 0.0f)}) {
    for (const auto& [fs, ft, v] :
         {std::tuple{1.0f, 1.0f, 1.0f}, std::tuple{0.0f, 1.0f, 0.6f}, std::tuple{0.3f, 0.0f, 0.5f}}) {
      auto irradiance = [&](const irm::testing::Light& l, float f) -> Eigen::Vector3f {
        return l.sun_irradiance * (f * std::max(0.0f, n.dot(l.sun_dir))) + l.sky_radiance * (pi * v);
      };
      const Eigen::Vector3f want =
          irradiance(s.target_light.light, ft).cwiseQuotient(irradiance(s.source_light.light, fs));
      const Eigen::Vector3f got = irm::RatioTable(set).Ratio(n, fs, ft, v);
      EXPECT_LT((got - want).cwiseQuotient(want).cwiseAbs().maxCoeff(), 1e-5f) << n.transpose() << " " << fs;
    }
  }
}

TEST(IrmSuiteTest, TheSameSeedGivesTheSameErrors) {
  SuiteOptions options;
  options.scenes = 1;
  options.seed = kSeed;
  options.quick = true;
  const std::vector<SuiteResult> again = RunIrmSuite(options);
  ASSERT_EQ(again.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const SceneResult& a = again[k].scenes[0];
    const SceneResult& b = QuickSuite()[k].scenes[0];
    EXPECT_EQ(a.seed, b.seed);
    EXPECT_EQ(a.description, b.description);
    if (std::isnan(b.method)) {
      EXPECT_TRUE(std::isnan(a.method));
    } else {
      EXPECT_DOUBLE_EQ(a.method, b.method);
      EXPECT_DOUBLE_EQ(a.floor, b.floor);
    }
  }
}

// The same scenes rendered with 3 diffuse bounces (InterreflectionTruth). Run as one CTest test
// (bench/CMakeLists.txt: WHOLE_SUITES), so the renders are made once.
constexpr int kBounceScenes = 4;

const std::vector<SuiteResult>& QuickBouncesSuite() {
  static const std::vector<SuiteResult> results = RunQuick(RunIrmBouncesSuite, kBounceScenes);
  return results;
}

TEST(IrmBouncesSuiteTest, RelightsTheSameScenesWithTheirInterreflection) {
  const std::vector<SuiteResult>& results = QuickBouncesSuite();
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[0].suite, "irm-outdoor-bounces-lit");
  EXPECT_EQ(results[1].suite, "irm-outdoor-bounces-shadow");
  EXPECT_DOUBLE_EQ(results[0].goal_median, 0.02);
  EXPECT_DOUBLE_EQ(results[1].goal_p90, 0.03);
  for (int i = 0; i < kBounceScenes; ++i) {
    const SceneResult& bounce = results[1].scenes[static_cast<std::size_t>(i)];
    // The same draw as the direct-light suite's scene of that seed.
    EXPECT_EQ(bounce.seed, SceneSeed(kSeed, i));
    EXPECT_EQ(bounce.description, Region("irm-outdoor-shadow").scenes[static_cast<std::size_t>(i)].description);
    // The method found the interreflection in the photographs and kept it (the direct-light
    // renders of the same scenes reject it: IrmSuiteTest).
    EXPECT_NE(bounce.notes.find("indirect light (share of the model's irradiance)"), std::string::npos) << bounce.notes;
    EXPECT_EQ(Region("irm-outdoor-shadow").scenes[static_cast<std::size_t>(i)].notes.find("indirect light (share"),
              std::string::npos);
  }
}

TEST(IrmBouncesSuiteTest, LitAndShadowErrorsStayWithinWhatWasMeasured) {
  const SuiteResult& lit = QuickBouncesSuite()[0];
  const SuiteResult& shadow = QuickBouncesSuite()[1];
  EXPECT_EQ(lit.method_errors.failed, 0);
  EXPECT_EQ(shadow.method_errors.failed, 0);
  // Measured (seed 3, 4 quick scenes, 2026-12-03): lit median 0.66 %, p90 0.90 %; shadow
  // median 2.05 %, p90 2.28 % (floor 1.95 / 2.15 %). Issue 26's goal: 2 % / 3 %.
  EXPECT_LT(lit.method_errors.median, 0.009);
  EXPECT_LT(shadow.method_errors.median, 0.025);
  EXPECT_LT(shadow.method_errors.p90, 0.03);
  // The floor (the true light and the true indirect light on the method's geometry) is below.
  EXPECT_LE(lit.floor_errors.median, lit.method_errors.median * 1.05);
  EXPECT_LE(shadow.floor_errors.median, shadow.method_errors.median * 1.05);
}

TEST(IrmBouncesSuiteTest, WhenNoFitHoldsPerSampleTheBinsDecideTheIndirectLight) {
  // Scene 11 of seed 1: no sky in the target photograph, and the per-sample fits go negative
  // with and without the indirect term (a target sun of -0.6), so until 2026-12-05 the indirect
  // light was left out: shadow 16.3 %, lit 4.6 % (floor 1.8 / 0.2 %). The bin means fitted with
  // the same known q keep it where the photographs have bounces (measured shadow 2.17 %, lit
  // 0.70 %) and leave it out where they have none (the direct-light render: shadow 1.34 %,
  // unchanged).
  SuiteOptions options;
  options.scene_seed = 10682531704454680323ull;
  options.quick = true;
  std::vector<SuiteResult> bounces = RunIrmBouncesSuite(options);
  std::vector<SuiteResult> direct = RunIrmSuite(options);
  ASSERT_EQ(bounces.size(), 3u);
  ASSERT_EQ(direct.size(), 3u);
  const SceneResult& shadow = bounces[1].scenes.at(0);
  EXPECT_NE(shadow.notes.find("indirect light (share of the model's irradiance)"), std::string::npos) << shadow.notes;
  EXPECT_LT(shadow.method, 0.025) << shadow.notes;
  EXPECT_LT(bounces[0].scenes.at(0).method, 0.01);
  const SceneResult& direct_shadow = direct[1].scenes.at(0);
  EXPECT_NE(direct_shadow.notes.find("no interreflection in these photographs"), std::string::npos)
      << direct_shadow.notes;
  EXPECT_LT(direct_shadow.method, 0.015);
}

}  // namespace
}  // namespace relume::bench
