// Validates the SPA against an independent reference (ERFA, IAU 2006/2000A) over many random
// times (1900-2100) and places (all latitudes, heights 0-5000 m). Requirement: the geometric
// elevation and the cos(elevation)-weighted azimuth within 0.0003 deg whenever the sun is
// above -5 deg.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/sun/erfa_sun_reference.h"
#include "core/sun/sun_position.h"
#include "core/sun/sun_track.h"

namespace relume {
namespace {

struct Sample {
  Site site;
  JulianDate jd_ut1;
  double delta_t_s;
};

std::vector<Sample> RandomSamples(int count, std::uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> sin_latitude(-1.0, 1.0);  // uniform over the sphere
  std::uniform_real_distribution<double> longitude(-180.0, 180.0);
  std::uniform_real_distribution<double> height(0.0, 5000.0);
  std::uniform_real_distribution<double> day(0.0, 73049.0);  // 1900-01-01 .. 2100-01-01
  std::uniform_real_distribution<double> delta_t(-5.0, 200.0);
  std::vector<Sample> samples;
  for (int i = 0; i < count; ++i) {
    Sample s;
    // Every 50th sample sits exactly on a pole or the equator to cover the edges.
    double lat = RadToDeg(std::asin(sin_latitude(rng)));
    if (i % 50 == 0) lat = 90.0;
    if (i % 50 == 1) lat = -90.0;
    if (i % 50 == 2) lat = 0.0;
    s.site = Site::FromDegrees(lat, longitude(rng), height(rng));
    const double d = day(rng);
    s.jd_ut1 = {2415020.5 + std::floor(d), d - std::floor(d)};
    s.delta_t_s = delta_t(rng);
    samples.push_back(s);
  }
  return samples;
}

struct Errors {
  double max_elevation_deg = 0.0;
  double max_weighted_azimuth_deg = 0.0;
  int compared = 0;
};

void Accumulate(Errors& errors, const testing::ErfaSunPosition& reference, double elevation_rad, double azimuth_rad) {
  if (RadToDeg(reference.elevation_rad) < -5.0) return;
  double d_az = std::remainder(azimuth_rad - reference.azimuth_rad, 2 * M_PI);
  errors.max_elevation_deg =
      std::max(errors.max_elevation_deg, RadToDeg(std::abs(elevation_rad - reference.elevation_rad)));
  errors.max_weighted_azimuth_deg =
      std::max(errors.max_weighted_azimuth_deg, RadToDeg(std::abs(d_az) * std::cos(reference.elevation_rad)));
  ++errors.compared;
}

TEST(SunErfaTest, SpaAgreesWithErfaOverRandomTimesAndPlaces) {
  const std::vector<Sample> samples = RandomSamples(12000, 20261122);
  Errors errors;
  for (const Sample& s : samples) {
    SunOptions options;
    options.delta_t_s = s.delta_t_s;
    options.pressure_hpa = 0.0;  // compare geometric positions
    const SunPosition spa = ComputeSunPositionAtJulianDate(s.site, s.jd_ut1, options);
    const testing::ErfaSunPosition erfa = testing::ErfaTopocentricSun(s.site, s.jd_ut1, s.delta_t_s);
    Accumulate(errors, erfa, spa.elevation_geometric_rad, spa.azimuth_rad);
    // SPA's distance is geocentric, ERFA's topocentric: they differ by up to one Earth radius
    // (4.3e-5 au).
    EXPECT_NEAR(spa.distance_au, erfa.distance_au, 5e-5);
  }
  std::printf(
      "SPA vs ERFA: %d samples with the sun above -5 deg; max |d elevation| = %.6f deg, "
      "max |d azimuth| cos(el) = %.6f deg\n",
      errors.compared, errors.max_elevation_deg, errors.max_weighted_azimuth_deg);
  EXPECT_GE(errors.compared, 5000);
  EXPECT_LE(errors.max_elevation_deg, 0.0003);
  EXPECT_LE(errors.max_weighted_azimuth_deg, 0.0003);
}

TEST(SunErfaTest, TimeSeriesPathAgreesWithErfa) {
  // One day at 10-minute steps for a handful of the random sites, through SunTrack.
  const std::vector<Sample> samples = RandomSamples(40, 7);
  Errors errors;
  for (const Sample& s : samples) {
    SunTrackOptions options;
    options.sun.delta_t_s = s.delta_t_s;
    options.sun.pressure_hpa = 0.0;
    SunTrack track(s.site, options);
    const UtcTime start = UtcTime(std::chrono::duration_cast<Nanoseconds>(
        std::chrono::duration<double, std::ratio<86400>>(s.jd_ut1.day - 2440587.5 + s.jd_ut1.fraction)));
    for (int step = 0; step < 144; ++step) {
      const UtcTime t = start + std::chrono::minutes(10 * step);
      const SunPosition fast = track.At(t);
      const testing::ErfaSunPosition erfa = testing::ErfaTopocentricSun(s.site, JulianDateFromUtc(t), s.delta_t_s);
      Accumulate(errors, erfa, fast.elevation_geometric_rad, fast.azimuth_rad);
    }
  }
  std::printf("SunTrack vs ERFA: %d instants; max |d elevation| = %.6f deg, max |d azimuth| cos(el) = %.6f deg\n",
              errors.compared, errors.max_elevation_deg, errors.max_weighted_azimuth_deg);
  EXPECT_GE(errors.compared, 1000);
  EXPECT_LE(errors.max_elevation_deg, 0.0003);
  EXPECT_LE(errors.max_weighted_azimuth_deg, 0.0003);
}

}  // namespace
}  // namespace relume
