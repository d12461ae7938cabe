#include "core/sun/sun_track.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"

namespace relume {
namespace {

double MaxDifferenceDeg(const Site& site, const SunTrackOptions& options, UtcTime start, Nanoseconds step, int count) {
  SunTrack track(site, options);
  double max_deg = 0.0;
  for (int i = 0; i < count; ++i) {
    const UtcTime t = start + step * i;
    const SunPosition fast = track.At(t);
    const SunPosition exact = ComputeSunPosition(site, t, options.sun);
    max_deg = std::max(max_deg, RadToDeg(std::abs(fast.elevation_rad - exact.elevation_rad)));
    max_deg = std::max(max_deg, RadToDeg(std::abs(std::remainder(fast.azimuth_rad - exact.azimuth_rad, 2 * M_PI)) *
                                         std::cos(exact.elevation_rad)));
    max_deg = std::max(max_deg, RadToDeg(std::abs(fast.declination_rad - exact.declination_rad)));
  }
  return max_deg;
}

TEST(SunTrackTest, MatchesPerCallSpaOverADay) {
  const Site site = Site::FromDegrees(37.97, 23.73, 150);  // Athens, the Parthenon
  SunTrackOptions options;
  const UtcTime start = ParseIso8601("2024-08-01T00:00:00Z").utc;
  const double max_deg = MaxDifferenceDeg(site, options, start, std::chrono::seconds(37), 86400 / 37);
  EXPECT_LT(max_deg, 1e-7);
}

TEST(SunTrackTest, RightAscensionWrapAtTheMarchEquinox) {
  // The sun's right ascension passes 360 -> 0 deg at the March equinox.
  const Site site = Site::FromDegrees(-33.9, 18.4, 20);
  SunTrackOptions options;
  options.node_spacing_hours = 24.0;
  const UtcTime start = ParseIso8601("2024-03-18T00:00:00Z").utc;
  EXPECT_LT(MaxDifferenceDeg(site, options, start, std::chrono::minutes(13), 5 * 24 * 60 / 13), 1e-5);
}

TEST(SunTrackTest, SpacingIsTheAccuracyKnob) {
  const Site site = Site::FromDegrees(64.1, -21.9, 30);
  const UtcTime start = ParseIso8601("2025-12-01T06:00:00Z").utc;
  SunTrackOptions coarse;
  coarse.node_spacing_hours = 48.0;
  SunTrackOptions fine;
  fine.node_spacing_hours = 1.0;
  const double coarse_error = MaxDifferenceDeg(site, coarse, start, std::chrono::minutes(7), 800);
  const double fine_error = MaxDifferenceDeg(site, fine, start, std::chrono::minutes(7), 800);
  EXPECT_LT(fine_error, coarse_error);
  EXPECT_LT(coarse_error, 0.0003);  // even 48 h spacing stays within the SPA's own accuracy
}

TEST(SunTrackTest, RandomOrderAndSeriesAgree) {
  const Site site = Site::FromDegrees(51.5, -0.12, 20);
  SunTrack sequential(site);
  const UtcTime start = ParseIso8601("2030-06-01T00:00:00Z").utc;
  const std::vector<SunPosition> series = sequential.Series(start, std::chrono::seconds(1), 86400);
  // A day at 1 s needs only a handful of exact evaluations.
  EXPECT_LE(sequential.nodes_evaluated(), 8);
  std::vector<int> order(2000);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pick(0, 86399);
  for (int& i : order) i = pick(rng);
  SunTrack random_access(site);
  for (int i : order) {
    const SunPosition p = random_access.At(start + std::chrono::seconds(i));
    EXPECT_DOUBLE_EQ(p.elevation_rad, series[static_cast<std::size_t>(i)].elevation_rad);
  }
}

TEST(SunTrackTest, RejectsInvalidOptions) {
  SunTrackOptions options;
  options.node_spacing_hours = 0.0;
  EXPECT_THROW(SunTrack(Site::FromDegrees(0, 0, 0), options), InvalidArgumentError);
  options.node_spacing_hours = NAN;
  EXPECT_THROW(SunTrack(Site::FromDegrees(0, 0, 0), options), InvalidArgumentError);
  EXPECT_THROW(SunTrack(Site{NAN, 0, 0}), InvalidArgumentError);
}

}  // namespace
}  // namespace relume
