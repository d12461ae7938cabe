#include "bench/suite.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>

#include "core/error.h"

namespace relume::bench {
namespace {

SceneResult Scene(std::uint64_t seed, double method, double floor) {
  SceneResult s;
  s.seed = seed;
  s.method = method;
  s.floor = floor;
  return s;
}

TEST(SuiteStatsTest, PercentileInterpolatesBetweenOrderStatistics) {
  // numpy.percentile([1..10], 90) = 9.1, median 5.5
  std::vector<double> v;
  for (int i = 10; i >= 1; --i) v.push_back(i);
  EXPECT_DOUBLE_EQ(Percentile(v, 50.0), 5.5);
  EXPECT_DOUBLE_EQ(Percentile(v, 90.0), 9.1);
  EXPECT_DOUBLE_EQ(Percentile(v, 100.0), 10.0);
  EXPECT_DOUBLE_EQ(Percentile({3.0}, 90.0), 3.0);
  EXPECT_TRUE(std::isnan(Percentile({}, 50.0)));
}

TEST(SuiteStatsTest, FailedScenesAreCountedAndMakeTheWorstInfinite) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Distribution d = Distribution::Of({0.1, nan, 0.3, 0.2});
  EXPECT_EQ(d.count, 3);
  EXPECT_EQ(d.failed, 1);
  EXPECT_DOUBLE_EQ(d.median, 0.2);
  EXPECT_TRUE(std::isinf(d.worst));
  const Distribution none = Distribution::Of({nan});
  EXPECT_EQ(none.count, 0);
  EXPECT_TRUE(std::isnan(none.median));
}

TEST(SuiteStatsTest, GoalNeedsMedianAndP90WithinAndNoFailure) {
  SuiteResult r;
  r.goal_median = 0.02;
  r.goal_p90 = 0.03;
  for (const double e : {0.01, 0.015, 0.02, 0.012, 0.025}) r.scenes.push_back(Scene(1, e, e / 2));
  r.Summarize();
  EXPECT_TRUE(r.MeetsGoal());
  r.scenes.push_back(Scene(2, 0.2, 0.1));
  r.scenes.push_back(Scene(3, 0.2, 0.1));
  r.Summarize();
  EXPECT_FALSE(r.MeetsGoal());  // p90 is now above 0.03
  SuiteResult no_goal;
  no_goal.scenes = {Scene(1, 0.0, 0.0)};
  no_goal.Summarize();
  EXPECT_FALSE(no_goal.MeetsGoal());
}

TEST(SuiteSeedTest, SceneSeedsDifferAndRepeat) {
  std::set<std::uint64_t> seeds;
  for (std::uint64_t suite = 0; suite < 4; ++suite) {
    for (int i = 0; i < 100; ++i) seeds.insert(SceneSeed(suite, i));
  }
  EXPECT_EQ(seeds.size(), 400u);
  EXPECT_EQ(SceneSeed(7, 3), SceneSeed(7, 3));
}

TEST(SuiteSeedTest, SceneRandomIsPortableAndInRange) {
  SceneRandom a(42), b(42);
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const double u = a.Uniform(-2.0, 3.0);
    EXPECT_EQ(u, b.Uniform(-2.0, 3.0));
    ASSERT_GE(u, -2.0);
    ASSERT_LT(u, 3.0);
    const int k = a.Int(1, 6);
    b.Int(1, 6);
    ASSERT_GE(k, 1);
    ASSERT_LE(k, 6);
    const double g = a.Gaussian();
    b.Gaussian();
    sum += g;
    sum2 += g * g;
  }
  EXPECT_NEAR(sum / 20000, 0.0, 0.03);
  EXPECT_NEAR(sum2 / 20000, 1.0, 0.05);
  // std::mt19937_64 is specified by the standard: its 10000th output of the default seed.
  std::mt19937_64 engine;
  engine.discard(9999);
  EXPECT_EQ(engine(), 9981545732273789042ULL);
}

TEST(SuiteRunTest, RefusesUnknownStagesAndBadOptions) {
  SuiteOptions options;
  EXPECT_THROW(RunSuites("no-such-stage", options), InvalidArgumentError);
  options.scenes = 0;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("scenes"), std::string::npos);
  EXPECT_THROW(RunSuites("all", options), InvalidArgumentError);
  options.scenes = 1;
  options.truth_rays_factor = 0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("truth_rays_factor"), std::string::npos);
}

TEST(SuiteOutputTest, WritesTableCsvAndJson) {
  SuiteResult r;
  r.suite = "example";
  r.stage = "x";
  r.metric = "relative RMS";
  r.floor = "the truth";
  r.scenes = {{11, 0.01, 0.005, 0.1, "two objects", "note, with comma"},
              {12, std::numeric_limits<double>::quiet_NaN(), 0.004, 0.1, "one object", "failed: why"}};
  r.Summarize();
  const std::string dir = ::testing::TempDir() + "/suite_output_test";
  std::filesystem::remove_all(dir);
  const std::string md = WriteSuiteOutputs(dir, {r}, SuiteOptions{});
  EXPECT_NE(md.find("| example | relative RMS | 1.00 % |"), std::string::npos) << md;
  EXPECT_NE(md.find("failed (1 failed)"), std::string::npos) << md;
  std::ifstream csv(dir + "/suite.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_EQ(first.substr(0, 17), "example,x,0,11,0.");
  EXPECT_NE(first.find("\"note, with comma\""), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir + "/suite.json"));
}

}  // namespace
}  // namespace relume::bench
