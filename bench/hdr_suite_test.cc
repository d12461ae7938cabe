#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "bench/suites.h"
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

// --- The suite ---

SuiteOptions QuickOptions(int scenes) {
  SuiteOptions options;
  options.scenes = scenes;
  options.seed = 1;
  options.quick = true;
  return options;
}

// Measured 2026-12-02 (Release, GCC 12), seed 1, 8 quick scenes (240 x 160):
//   relume  median 1.56 %, p90 2.68 %, worst 2.81 %
//   floor   median 1.50 %, p90 2.50 %, worst 2.52 %   (MergeHdr with the true response)
//   OpenCV  median 3.03 %, p90 5.85 %, worst 5.92 %
//   relume / floor per scene 1.01 to 1.13.
// The thresholds are a small margin above. The floor is sensor noise (about 1.6 x
// sqrt(shot_noise) per scene; without noise it is 0.3-0.4 %), which is why it is above the
// issue's 1 % goal on these noise levels.
TEST(HdrSuiteTest, RelumeIsNearItsFloorAndBeatsOpenCv) {
  std::vector<SuiteResult> results = RunHdrSuite(QuickOptions(8));
  for (SuiteResult& r : results) r.Summarize();
  ASSERT_EQ(results.size(), 2u);
  const SuiteResult& ours = results[0];
  const SuiteResult& opencv = results[1];
  EXPECT_EQ(ours.suite, "hdr-random-response");
  EXPECT_EQ(opencv.suite, "hdr-opencv-debevec");
  EXPECT_NE(ours.metric.find("relative"), std::string::npos);
  ASSERT_EQ(ours.scenes.size(), 8u);
  EXPECT_EQ(ours.method_errors.failed, 0);
  EXPECT_EQ(opencv.method_errors.failed, 0);

  EXPECT_LT(ours.method_errors.median, 0.0170);
  EXPECT_LT(ours.method_errors.p90, 0.0290);
  EXPECT_LT(ours.floor_errors.median, 0.0165);
  EXPECT_LT(ours.floor_errors.p90, 0.0270);
  EXPECT_LT(ours.floor_errors.median, ours.method_errors.median);
  EXPECT_LT(ours.method_errors.median, opencv.method_errors.median);
  for (const SceneResult& s : ours.scenes) {
    EXPECT_GT(s.floor, 0.0);
    EXPECT_LT(s.method / s.floor, 1.25) << s.description << "; " << s.notes;
  }
  // OpenCV sees the same scenes and the same floor.
  for (std::size_t i = 0; i < ours.scenes.size(); ++i) {
    EXPECT_EQ(opencv.scenes[i].seed, ours.scenes[i].seed);
    EXPECT_EQ(opencv.scenes[i].floor, ours.scenes[i].floor);
  }
  // Scene 0 alone is scene 0 of the suite: a scene does not depend on the ones before it.
  const std::vector<SuiteResult> alone = RunHdrSuite(QuickOptions(1));
  EXPECT_EQ(alone[0].scenes[0].description, ours.scenes[0].description);
  EXPECT_EQ(alone[0].scenes[0].method, ours.scenes[0].method);
  EXPECT_NE(ours.scenes[0].description.find("response "), std::string::npos);
  EXPECT_NE(ours.scenes[0].notes.find("response log-RMS"), std::string::npos);
}

TEST(HdrSuiteTest, ASceneIsDeterministic) {
  // Scene 0 of seed 1, drawn and run twice (its own process under ctest: no shared state).
  const std::vector<SuiteResult> a = RunHdrSuite(QuickOptions(1));
  const std::vector<SuiteResult> b = RunHdrSuite(QuickOptions(1));
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  ASSERT_EQ(a[0].scenes.size(), 1u);
  ASSERT_EQ(b[0].scenes.size(), 1u);
  EXPECT_EQ(a[0].scenes[0].seed, SceneSeed(1, 0));
  EXPECT_EQ(a[0].scenes[0].description, b[0].scenes[0].description);
  EXPECT_TRUE(std::isfinite(a[0].scenes[0].method));
  EXPECT_EQ(a[0].scenes[0].method, b[0].scenes[0].method);
  EXPECT_EQ(a[0].scenes[0].floor, b[0].scenes[0].floor);
  EXPECT_EQ(a[1].scenes[0].method, b[1].scenes[0].method);
}

}  // namespace
}  // namespace relume::bench
