#include "core/sun/spa.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/sun/sun_position.h"

namespace relume {
namespace {

// The example published with the SPA (Reda & Andreas 2004, table A5.1):
// 2003-10-17 12:30:30 local time at UTC-7, 39.742476 N, 105.1786 W, 1830.14 m,
// 820 mbar, 11 C, delta_t 67 s, dut1 0.
Site PaperSite() {
  return Site::FromDegrees(39.742476, -105.1786, 1830.14);
}
SunOptions PaperOptions() {
  SunOptions options;
  options.delta_t_s = 67.0;
  options.dut1_s = 0.0;
  options.pressure_hpa = 820.0;
  options.temperature_c = 11.0;
  options.horizon_refraction_deg = 0.5667;
  return options;
}
UtcTime PaperTime() {
  return ParseIso8601("2003-10-17T12:30:30-07:00").utc;
}

TEST(SpaTest, PaperExampleIntermediateValues) {
  const JulianDate jd = JulianDateFromUtc(PaperTime());
  EXPECT_NEAR(jd.Value(), 2452930.312847, 1e-6);
  const spa::GeocentricSun sun = spa::ComputeGeocentricSun(jd.Value() + 67.0 / 86400.0);
  EXPECT_NEAR(sun.heliocentric_longitude_deg, 24.0182616917, 1e-8);
  EXPECT_NEAR(sun.heliocentric_latitude_deg, -0.0001011219, 1e-10);
  EXPECT_NEAR(sun.distance_au, 0.9965422974, 1e-10);
  EXPECT_NEAR(sun.nutation_longitude_deg, -0.00399840, 1e-8);
  EXPECT_NEAR(sun.nutation_obliquity_deg, 0.00166657, 1e-8);
  EXPECT_NEAR(sun.true_obliquity_deg, 23.440465, 1e-6);
  EXPECT_NEAR(sun.apparent_longitude_deg, 204.0085519281, 1e-8);
  EXPECT_NEAR(sun.right_ascension_deg, 202.22741, 1e-5);
  EXPECT_NEAR(sun.declination_deg, -9.31434, 1e-5);
  const double nu = spa::GreenwichMeanSiderealTimeDeg(jd) + sun.equation_of_equinoxes_deg;
  EXPECT_NEAR(nu, 318.5119, 1e-4);
}

TEST(SpaTest, PaperExampleZenithAndAzimuth) {
  const SunPosition sun = ComputeSunPosition(PaperSite(), PaperTime(), PaperOptions());
  EXPECT_NEAR(RadToDeg(sun.zenith_rad), 50.11162, 1e-5);
  EXPECT_NEAR(RadToDeg(sun.azimuth_rad), 194.34024, 1e-5);
  EXPECT_NEAR(RadToDeg(sun.hour_angle_rad), 11.10627, 1e-5);  // H - delta alpha
  EXPECT_NEAR(RadToDeg(sun.declination_rad), -9.316179, 1e-6);
  EXPECT_NEAR(sun.elevation_rad + sun.zenith_rad, M_PI / 2, 1e-12);
  EXPECT_DOUBLE_EQ(sun.delta_t_s, 67.0);
}

TEST(SpaTest, PaperExampleSunriseTransitSunset) {
  const SunDayEvents events = ComputeSunDayEvents(PaperSite(), {2003, 10, 17}, std::chrono::hours(-7), PaperOptions());
  ASSERT_EQ(events.kind, SunDayKind::kNormal);
  ASSERT_TRUE(events.sunrise && events.transit && events.sunset);
  // Published: sunrise 06:12:43, transit 11:46:04, sunset 17:20:19 local time. The paper's
  // sunset is that of the UT day (Oct 17 UT), which at UTC-7 falls on the evening of Oct 16
  // local time; relume reports the sunset of the asked local day, Oct 17, 87 s earlier
  // (the day shortens by ~2.5 min a day in October at 40 N).
  auto seconds_after_local_midnight = [](UtcTime t) {
    const UtcTime midnight = ParseIso8601("2003-10-17T00:00:00-07:00").utc;
    return std::chrono::duration<double>(t - midnight).count();
  };
  EXPECT_NEAR(seconds_after_local_midnight(*events.sunrise), 6 * 3600 + 12 * 60 + 43, 1.0);
  EXPECT_NEAR(seconds_after_local_midnight(*events.transit), 11 * 3600 + 46 * 60 + 4, 1.0);
  EXPECT_NEAR(seconds_after_local_midnight(*events.sunset), 17 * 3600 + 20 * 60 + 19 - 87, 2.0);
  const SunPosition at_sunset = ComputeSunPosition(PaperSite(), *events.sunset, PaperOptions());
  EXPECT_NEAR(RadToDeg(at_sunset.elevation_geometric_rad), -0.8333, 0.003);
  // The paper's sunset of the previous local evening, 24 h earlier on the clock:
  const SunDayEvents previous =
      ComputeSunDayEvents(PaperSite(), {2003, 10, 16}, std::chrono::hours(-7), PaperOptions());
  ASSERT_TRUE(previous.sunset);
  EXPECT_NEAR(seconds_after_local_midnight(*previous.sunset) + 86400.0, 17 * 3600 + 20 * 60 + 19, 1.0);
}

TEST(SpaTest, SunriseElevationIsAtTheRefractedHorizon) {
  // At the computed sunrise the geometric centre is 0.8333 deg below the horizon.
  const Site site = Site::FromDegrees(48.85, 2.35, 35);
  SunOptions options;
  options.delta_t_s = 69.0;
  const SunDayEvents events = ComputeSunDayEvents(site, {2024, 6, 21}, std::chrono::hours(2), options);
  ASSERT_TRUE(events.sunrise && events.sunset);
  for (UtcTime t : {*events.sunrise, *events.sunset}) {
    const SunPosition sun = ComputeSunPosition(site, t, options);
    EXPECT_NEAR(RadToDeg(sun.elevation_geometric_rad), -0.8333, 0.005);
  }
  const SunPosition at_transit = ComputeSunPosition(site, *events.transit, options);
  EXPECT_NEAR(std::abs(RadToDeg(at_transit.hour_angle_rad)), 0.0, 0.01);
}

TEST(SpaTest, PolarDayAndPolarNight) {
  SunOptions options;
  const Site svalbard = Site::FromDegrees(78.22, 15.65, 10);
  EXPECT_EQ(ComputeSunDayEvents(svalbard, {2024, 6, 21}, std::chrono::hours(2), options).kind, SunDayKind::kPolarDay);
  const SunDayEvents night = ComputeSunDayEvents(svalbard, {2024, 12, 21}, std::chrono::hours(1), options);
  EXPECT_EQ(night.kind, SunDayKind::kPolarNight);
  EXPECT_FALSE(night.sunrise);
  EXPECT_FALSE(night.sunset);
  EXPECT_LT(night.transit_elevation_rad, 0.0);
  // The geographic poles: still a defined outcome, no NaN.
  const SunPosition pole = ComputeSunPosition(Site::FromDegrees(90, 0, 0), PaperTime(), options);
  EXPECT_TRUE(std::isfinite(pole.elevation_rad));
  EXPECT_TRUE(std::isfinite(pole.azimuth_rad));
  const SunDayEvents south = ComputeSunDayEvents(Site::FromDegrees(-90, 0, 2800), {2024, 6, 21}, {}, options);
  EXPECT_EQ(south.kind, SunDayKind::kPolarNight);
}

TEST(SpaTest, ZeroPressureMeansNoRefraction) {
  SunOptions options = PaperOptions();
  options.pressure_hpa = 0.0;
  const SunPosition sun = ComputeSunPosition(PaperSite(), PaperTime(), options);
  EXPECT_EQ(sun.refraction_rad, 0.0);
  EXPECT_EQ(sun.elevation_rad, sun.elevation_geometric_rad);
  const SunPosition refracted = ComputeSunPosition(PaperSite(), PaperTime(), PaperOptions());
  EXPECT_GT(refracted.refraction_rad, 0.0);
  EXPECT_NEAR(refracted.elevation_geometric_rad, sun.elevation_geometric_rad, 1e-15);
}

TEST(SpaTest, SunBelowHorizonHasNoRefractionAndValidAngles) {
  const SunPosition night =
      ComputeSunPosition(PaperSite(), ParseIso8601("2003-10-17T23:30:00-07:00").utc, PaperOptions());
  EXPECT_LT(night.elevation_rad, 0.0);
  EXPECT_EQ(night.refraction_rad, 0.0);
  EXPECT_GE(night.azimuth_rad, 0.0);
  EXPECT_LT(night.azimuth_rad, 2 * M_PI);
}

TEST(SpaTest, RejectsInvalidInput) {
  SunOptions options;
  EXPECT_THROW(ComputeSunPosition(Site{DegToRad(91.0), 0, 0}, PaperTime(), options), InvalidArgumentError);
  EXPECT_THROW(ComputeSunPosition(Site{NAN, 0, 0}, PaperTime(), options), InvalidArgumentError);
  options.pressure_hpa = NAN;
  EXPECT_THROW(ComputeSunPosition(PaperSite(), PaperTime(), options), InvalidArgumentError);
  options = {};
  options.dut1_s = 1.5;
  EXPECT_THROW(ComputeSunPosition(PaperSite(), PaperTime(), options), InvalidArgumentError);
  options = {};
  options.delta_t_s = INFINITY;
  EXPECT_THROW(ComputeSunPosition(PaperSite(), PaperTime(), options), InvalidArgumentError);
  // Julian-date API: years outside -2000..6000 and a missing delta_t are errors.
  options = {};
  options.delta_t_s = 0.0;
  EXPECT_THROW(ComputeSunPositionAtJulianDate(PaperSite(), {100000.5, 0.0}, options), InvalidArgumentError);
  EXPECT_THROW(ComputeSunPositionAtJulianDate(PaperSite(), {4000000.5, 0.0}, options), InvalidArgumentError);
  EXPECT_THROW(ComputeSunPositionAtJulianDate(PaperSite(), {NAN, 0.0}, options), InvalidArgumentError);
  options.delta_t_s = NAN;
  EXPECT_THROW(ComputeSunPositionAtJulianDate(PaperSite(), {2452930.5, 0.0}, options), InvalidArgumentError);
}

TEST(SpaTest, FarDatesThroughTheJulianDateApi) {
  SunOptions options;
  options.delta_t_s = 0.0;
  options.pressure_hpa = 0.0;
  // Year -1000 and 5000: finite, in range angles.
  for (double jd : {1355807.5, 3547272.5}) {
    const SunPosition sun = ComputeSunPositionAtJulianDate(PaperSite(), {jd, 0.25}, options);
    EXPECT_TRUE(std::isfinite(sun.elevation_rad));
    EXPECT_GE(sun.azimuth_rad, 0.0);
    EXPECT_NEAR(sun.distance_au, 1.0, 0.02);
  }
  // The same instant through both APIs agrees.
  const JulianDate jd = JulianDateFromUtc(PaperTime());
  const SunPosition a = ComputeSunPositionAtJulianDate(PaperSite(), jd, PaperOptions());
  const SunPosition b = ComputeSunPosition(PaperSite(), PaperTime(), PaperOptions());
  EXPECT_DOUBLE_EQ(a.zenith_rad, b.zenith_rad);
}

TEST(SpaTest, DutOneShiftsTheHourAngle) {
  SunOptions options = PaperOptions();
  const SunPosition base = ComputeSunPosition(PaperSite(), PaperTime(), options);
  options.dut1_s = 0.5;
  const SunPosition shifted = ComputeSunPosition(PaperSite(), PaperTime(), options);
  // 0.5 s more of Earth rotation (360.9856 deg/day) while the sun also moves 0.5 s along its
  // orbit (TT = UT1 + delta_t moves too, ~0.986 deg/day): the hour angle grows by ~360 deg/day.
  EXPECT_NEAR(RadToDeg(shifted.hour_angle_rad - base.hour_angle_rad), 0.5 * 360.0 / 86400.0, 1e-6);
}

}  // namespace
}  // namespace relume
