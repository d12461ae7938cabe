#include "capture/bracket_planner.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "core/error.h"

namespace relume::capture {
namespace {

drivers::ExposureCapabilities DslrCaps() {
  drivers::ExposureCapabilities caps;
  caps.control = drivers::ExposureControl::kShutterList;
  // 1/8000 s .. 30 s in third stops.
  for (int i = 0;; ++i) {
    const double t = std::exp2(-13.0 + i / 3.0);
    if (t > 30.5) break;
    caps.shutter_speeds_s.push_back(t);
  }
  return caps;
}

drivers::ExposureCapabilities MachineVisionCaps() {
  drivers::ExposureCapabilities caps;
  caps.control = drivers::ExposureControl::kContinuous;
  caps.min_exposure_time_s = 10e-6;
  caps.max_exposure_time_s = 10.0;
  return caps;
}

drivers::ExposureCapabilities EvOnlyCaps() {
  drivers::ExposureCapabilities caps;
  caps.control = drivers::ExposureControl::kEvOnly;
  for (int i = -15; i <= 15; ++i) caps.ev_steps.push_back(i / 3.0);
  return caps;
}

// Every radiance between the scene's dark and bright ends has usable signal in some frame.
void ExpectCoverage(const BracketPlan& plan, const MeteringStats& m, const BracketPlannerOptions& o) {
  const double dark = m.dark_signal / m.relative_exposure;
  const double bright = m.bright_signal / m.relative_exposure;
  for (double stops = 0; stops <= std::log2(bright / dark) + 1e-9; stops += 0.05) {
    const double radiance = dark * std::exp2(stops);
    bool usable = false;
    for (const PlannedExposure& e : plan.exposures) {
      const double s = radiance * e.relative_exposure;
      usable = usable || (s >= o.min_signal_fraction * 0.99 && s <= o.saturation_fraction * 1.01);
    }
    EXPECT_TRUE(usable) << "radiance at " << stops << " stops above the dark end is not covered";
  }
}

TEST(BracketPlannerTest, SeventeenStops) {
  // Stumpfel et al. covered 17 stops of sun and sky in seven exposures 3 stops apart with an
  // 8-bit-usable camera. With the default usable range of log2(0.9 / 0.04) = 4.49 stops per
  // frame and 1 stop of overlap (steps of 3.49 stops), the exposures must span
  // 17 - 4.49 = 12.5 stops: ceil(12.5 / 3.49) + 1 = 5 frames.
  MeteringStats m;
  m.dark_signal = 0.2 * std::exp2(-17.0);
  m.bright_signal = 0.2;
  const BracketPlannerOptions o;
  const BracketPlan plan = PlanBracket(m, MachineVisionCaps(), 1e-4, 0.0, o);
  EXPECT_EQ(plan.exposures.size(), 5u) << plan.reason;
  EXPECT_NEAR(plan.scene_range_stops, 17.0, 1e-9);
  ExpectCoverage(plan, m, o);
  EXPECT_TRUE(plan.covers_range);
}

// Steps alternate longer and shorter (two exposure ratios: the response is recoverable from
// the bracket), within the coverage the overlap allows; equal when asked.
TEST(BracketPlannerTest, StepsAlternateWithinCoverageUnlessEqualStepsAreAsked) {
  MeteringStats m;
  m.bright_signal = 0.2;
  auto gaps = [](const BracketPlan& plan) {
    std::vector<double> out;
    for (std::size_t i = 0; i + 1 < plan.exposures.size(); ++i) {
      out.push_back(std::log2(plan.exposures[i + 1].relative_exposure / plan.exposures[i].relative_exposure));
    }
    return out;
  };
  for (const double span_stops : {10.0, 12.5, 17.0}) {  // 3, 4 and 5 exposures
    m.dark_signal = m.bright_signal * std::exp2(-span_stops);
    const BracketPlannerOptions unequal;
    const BracketPlan plan = PlanBracket(m, MachineVisionCaps(), 1e-4, 0.0, unequal);
    EXPECT_TRUE(plan.covers_range) << plan.reason;
    ASSERT_GE(plan.exposures.size(), 3u) << span_stops;
    ExpectCoverage(plan, m, unequal);
    const std::vector<double> g = gaps(plan);
    const auto [lo, hi] = std::minmax_element(g.begin(), g.end());
    EXPECT_GT(*hi - *lo, 0.2 * *hi) << span_stops << " stops: " << plan.reason;
    EXPECT_NE(plan.reason.find("steps alternate"), std::string::npos) << plan.reason;
    BracketPlannerOptions equal;
    equal.unequal_steps = 0.0;
    const BracketPlan even = PlanBracket(m, MachineVisionCaps(), 1e-4, 0.0, equal);
    ExpectCoverage(even, m, equal);
    const std::vector<double> e = gaps(even);
    for (double x : e) EXPECT_NEAR(x, e.front(), 1e-9);
    // At most one exposure more for the unequal steps.
    EXPECT_LE(plan.exposures.size(), even.exposures.size() + 1);
  }
  // A DSLR's third-stop shutter list keeps them unequal.
  m.dark_signal = m.bright_signal * std::exp2(-12.5);
  const BracketPlan dslr = PlanBracket(m, DslrCaps(), 1.0 / 250, 0.0, BracketPlannerOptions{});
  const std::vector<double> d = gaps(dslr);
  const auto [lo, hi] = std::minmax_element(d.begin(), d.end());
  EXPECT_GT(*hi - *lo, 0.3) << dslr.reason;
  BracketPlannerOptions bad;
  bad.unequal_steps = 0.7;
  EXPECT_FALSE(bad.IsValid(nullptr));
}

TEST(BracketPlannerTest, OneExposureWhenTheSceneFits) {
  MeteringStats m;
  m.dark_signal = 0.1;
  m.bright_signal = 0.5;
  const BracketPlan plan = PlanBracket(m, DslrCaps(), 1.0 / 125, 0.0, BracketPlannerOptions{});
  ASSERT_EQ(plan.exposures.size(), 1u);
  EXPECT_NE(plan.reason.find("fits one exposure"), std::string::npos);
  // Chosen so that the bright end does not saturate: a list value at or below 0.9/0.5 x 1/125.
  EXPECT_LE(*plan.exposures[0].exposure_time_s, 0.9 / 0.5 / 125 + 1e-12);
}

TEST(BracketPlannerTest, ShutterListPlansStayOnTheListAndCover) {
  MeteringStats m;
  m.dark_signal = 0.003;
  m.bright_signal = 0.8;
  const BracketPlannerOptions o;
  const drivers::ExposureCapabilities caps = DslrCaps();
  const BracketPlan plan = PlanBracket(m, caps, 1.0 / 60, 0.0, o);
  ASSERT_GE(plan.exposures.size(), 2u);
  for (const PlannedExposure& e : plan.exposures) {
    ASSERT_TRUE(e.exposure_time_s);
    EXPECT_NE(std::find(caps.shutter_speeds_s.begin(), caps.shutter_speeds_s.end(), *e.exposure_time_s),
              caps.shutter_speeds_s.end());
  }
  for (std::size_t i = 1; i < plan.exposures.size(); ++i) {
    EXPECT_GT(plan.exposures[i].relative_exposure, plan.exposures[i - 1].relative_exposure);
  }
  ExpectCoverage(plan, m, o);
}

TEST(BracketPlannerTest, EvOnlyCamerasGetEvSteps) {
  MeteringStats m;
  m.dark_signal = 0.004;
  m.bright_signal = 0.85;
  const BracketPlannerOptions o;
  const BracketPlan plan = PlanBracket(m, EvOnlyCaps(), NAN, 0.0, o);
  ASSERT_GE(plan.exposures.size(), 2u);
  for (const PlannedExposure& e : plan.exposures) {
    ASSERT_TRUE(e.ev_compensation);
    EXPECT_FALSE(e.exposure_time_s);
    EXPECT_NEAR(e.relative_exposure, std::exp2(*e.ev_compensation), 1e-12);
  }
  ExpectCoverage(plan, m, o);
}

TEST(BracketPlannerTest, ClippedMeteringPlansDarkerAndExtendsAdaptively) {
  MeteringStats m;
  m.dark_signal = 0.05;
  m.bright_signal = 1.0;
  m.clipped_share = 0.2;
  const BracketPlannerOptions o;
  const drivers::ExposureCapabilities caps = MachineVisionCaps();
  const BracketPlan plan = PlanBracket(m, caps, 1e-2, 0.0, o);
  EXPECT_FALSE(plan.range_known);
  EXPECT_LT(plan.exposures.front().relative_exposure, 0.9 / 8 * 1.0001);  // 3 stops darker than clipping
  // The darkest frame still clips (the sun): one more, darker exposure, overlapping by a stop.
  MeteringStats darkest;
  darkest.clipped_share = 0.01;
  const auto extra = ExtendDarker(darkest, plan.exposures.front(), caps, 1e-2, 0.0, o);
  ASSERT_TRUE(extra);
  EXPECT_LT(extra->relative_exposure, plan.exposures.front().relative_exposure);
  EXPECT_GT(extra->relative_exposure, plan.exposures.front().relative_exposure / 16.0);
  darkest.clipped_share = 0.0;
  EXPECT_FALSE(ExtendDarker(darkest, plan.exposures.front(), caps, 1e-2, 0.0, o));
}

TEST(BracketPlannerTest, UnmeteredBracketsSpanTheAskedStopsInEveryMode) {
  const BracketPlannerOptions o;
  for (const auto& [name, caps, metering_s] :
       {std::tuple{"shutter list", DslrCaps(), 1.0 / 60}, std::tuple{"continuous", MachineVisionCaps(), 1e-3},
        std::tuple{"EV only", EvOnlyCaps(), double{NAN}}}) {
    const BracketPlan plan = PlanUnmeteredBracket(caps, metering_s, 0.0, o, 4.0);
    ASSERT_GE(plan.exposures.size(), 3u) << name;
    EXPECT_FALSE(plan.range_known) << name;
    EXPECT_NE(plan.reason.find("not metered"), std::string::npos) << plan.reason;
    // The darkest frame keeps a region 4 stops above the metering frame's clipping unclipped;
    // the brightest lifts one 4 stops below its noise floor into usable signal.
    EXPECT_LE(plan.exposures.front().relative_exposure, o.saturation_fraction / std::exp2(4.0) * 1.26) << name;
    EXPECT_GE(plan.exposures.back().relative_exposure, std::exp2(4.0) * 0.79) << name;
  }
  EXPECT_THROW(PlanUnmeteredBracket(MachineVisionCaps(), 1e-3, 0.0, o, -1.0), InvalidArgumentError);
}

TEST(BracketPlannerTest, CameraLimitsAndMaxExposuresAreReported) {
  MeteringStats m;
  m.dark_signal = 1e-4;
  m.bright_signal = 0.9;
  BracketPlannerOptions o;
  o.max_exposures = 2;
  const BracketPlan plan = PlanBracket(m, MachineVisionCaps(), 1e-3, 0.0, o);
  EXPECT_EQ(plan.exposures.size(), 2u);
  EXPECT_FALSE(plan.covers_range);
  EXPECT_NE(plan.reason.find("max_exposures"), std::string::npos);
  // A black metering frame: a defined plan with the reason, no NaN.
  MeteringStats black;
  const BracketPlan guess = PlanBracket(black, MachineVisionCaps(), 1e-3, 0.0, BracketPlannerOptions{});
  EXPECT_FALSE(guess.exposures.empty());
  for (const auto& e : guess.exposures) EXPECT_TRUE(std::isfinite(e.relative_exposure));
  EXPECT_NE(guess.reason.find("no signal"), std::string::npos);
}

TEST(BracketPlannerTest, MeteringLinearisesAndMeasures) {
  CameraImage frame;
  frame.pixels = cv::Mat(10, 100, CV_16UC1);
  for (int x = 0; x < 100; ++x) frame.pixels.col(x).setTo(64 + x * 40);  // 64 .. 4024
  frame.pixels.col(99).setTo(4095);                                      // one clipped column
  frame.layout = ColorLayout::kMono;
  frame.encoding = SampleEncoding::kSensorLinear;
  frame.bits_per_sample = 12;
  frame.black_level = 64;
  frame.white_level = 4095;
  BracketPlannerOptions o;
  o.dark_percentile = 0.0;
  o.bright_percentile = 0.98;
  const MeteringStats stats = MeasureMeteringFrame(frame, 2.0, o);
  EXPECT_NEAR(stats.dark_signal, 0.0, 1e-12);
  EXPECT_NEAR(stats.bright_signal, (64 + 98 * 40 - 64) / 4031.0, 1e-9);
  EXPECT_NEAR(stats.clipped_share, 0.01, 1e-12);
  EXPECT_NEAR(stats.black_share, 0.01, 1e-12);
  o.overlap_stops = 10;
  EXPECT_THROW(MeasureMeteringFrame(frame, 2.0, o), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::capture
