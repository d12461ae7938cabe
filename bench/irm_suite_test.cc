#include "bench/irm_suite.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bench/suites.h"

namespace relume::bench {
namespace {

// The quick suite's errors on a fixed seed. Thresholds: a small margin above what was measured
// (the figures in the comments, Release and ASan alike: the suite is deterministic).
constexpr int kScenes = 6;
constexpr std::uint64_t kSeed = 20;

const std::vector<SuiteResult>& QuickSuite() {
  static const std::vector<SuiteResult> results = [] {
    SuiteOptions options;
    options.scenes = kScenes;
    options.seed = kSeed;
    options.quick = true;
    std::vector<SuiteResult> r = RunIrmSuite(options);
    for (SuiteResult& s : r) s.Summarize();
    return r;
  }();
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
  // Measured (seed 20, 6 quick scenes): see below.
  EXPECT_LT(lit.method_errors.median, 1.0);
  EXPECT_LT(lit.method_errors.p90, 1.0);
  EXPECT_LT(shadow.method_errors.median, 1.0);
  EXPECT_LT(shadow.method_errors.p90, 1.0);
}

TEST(IrmSuiteTest, TheFloorIsAtOrBelowTheMethod) {
  for (const char* name : {"irm-outdoor-lit", "irm-outdoor-shadow"}) {
    const SuiteResult& r = Region(name);
    EXPECT_LE(r.floor_errors.median, r.method_errors.median) << name;
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

}  // namespace
}  // namespace relume::bench
