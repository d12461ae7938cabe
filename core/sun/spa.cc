#include "core/sun/spa.h"

#include <cmath>
#include <span>

#include "core/sun/spa_tables.h"

namespace relume::spa {

namespace {

using spa_tables::EarthTerm;

double Sin(double deg) {
  return std::sin(DegToRad(deg));
}
double Cos(double deg) {
  return std::cos(DegToRad(deg));
}

double SumTerms(std::span<const EarthTerm> terms, double jme) {
  double sum = 0.0;
  for (const EarthTerm& term : terms) sum += term.a * std::cos(term.b + term.c * jme);
  return sum;
}

// sum_i (series_i evaluated at jme) * jme^i / 1e8.
double EarthValue(std::initializer_list<std::span<const EarthTerm>> series, double jme) {
  double value = 0.0;
  double power = 1.0;
  for (const auto& terms : series) {
    value += SumTerms(terms, jme) * power;
    power *= jme;
  }
  return value / 1e8;
}

double Cubic(double a, double b, double c, double d, double x) {
  return ((a * x + b) * x + c) * x + d;
}

}  // namespace

double WrapDegrees360(double degrees) {
  double wrapped = std::fmod(degrees, 360.0);
  if (wrapped < 0.0) wrapped += 360.0;
  return wrapped >= 360.0 ? 0.0 : wrapped;
}

GeocentricSun ComputeGeocentricSun(double jde_tt) {
  const double jce = (jde_tt - 2451545.0) / 36525.0;  // Julian ephemeris centuries from J2000
  const double jme = jce / 10.0;                      // ... millennia

  GeocentricSun sun;
  sun.heliocentric_longitude_deg = WrapDegrees360(RadToDeg(EarthValue(
      {spa_tables::kL0, spa_tables::kL1, spa_tables::kL2, spa_tables::kL3, spa_tables::kL4, spa_tables::kL5}, jme)));
  sun.heliocentric_latitude_deg = RadToDeg(EarthValue({spa_tables::kB0, spa_tables::kB1}, jme));
  sun.distance_au =
      EarthValue({spa_tables::kR0, spa_tables::kR1, spa_tables::kR2, spa_tables::kR3, spa_tables::kR4}, jme);

  // Geocentric = heliocentric seen from the other side.
  const double geocentric_longitude_deg = WrapDegrees360(sun.heliocentric_longitude_deg + 180.0);
  const double geocentric_latitude_deg = -sun.heliocentric_latitude_deg;

  // Nutation from the Moon's and Sun's fundamental arguments (degrees).
  const double x[5] = {
      Cubic(1.0 / 189474.0, -0.0019142, 445267.11148, 297.85036, jce),  // mean elongation Moon-Sun
      Cubic(-1.0 / 300000.0, -0.0001603, 35999.05034, 357.52772, jce),  // mean anomaly Sun
      Cubic(1.0 / 56250.0, 0.0086972, 477198.867398, 134.96298, jce),   // mean anomaly Moon
      Cubic(1.0 / 327270.0, -0.0036825, 483202.017538, 93.27191, jce),  // Moon argument of latitude
      Cubic(1.0 / 450000.0, 0.0020708, -1934.136261, 125.04452, jce),   // Moon ascending node
  };
  double sum_psi = 0.0;
  double sum_epsilon = 0.0;
  for (const spa_tables::NutationTerm& term : spa_tables::kNutation) {
    double argument_deg = 0.0;
    for (int i = 0; i < 5; ++i) argument_deg += x[i] * term.y[i];
    sum_psi += (term.a + term.b * jce) * Sin(argument_deg);
    sum_epsilon += (term.c + term.d * jce) * Cos(argument_deg);
  }
  sun.nutation_longitude_deg = sum_psi / 36'000'000.0;  // 0.0001 arcsec -> degrees
  sun.nutation_obliquity_deg = sum_epsilon / 36'000'000.0;

  // Mean obliquity of the ecliptic (Laskar's polynomial, arcsec), U in 10^4 Julian years.
  const double u = jme / 10.0;
  static constexpr double kObliquity[] = {84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67,
                                          -39.05,    7.12,     27.87, 5.79,    2.45};
  double mean_obliquity_arcsec = 0.0;
  for (int i = 10; i >= 0; --i) mean_obliquity_arcsec = mean_obliquity_arcsec * u + kObliquity[i];
  sun.true_obliquity_deg = mean_obliquity_arcsec / 3600.0 + sun.nutation_obliquity_deg;

  // Annual aberration, then apparent longitude.
  const double aberration_deg = -20.4898 / (3600.0 * sun.distance_au);
  sun.apparent_longitude_deg = geocentric_longitude_deg + sun.nutation_longitude_deg + aberration_deg;

  const double lambda_rad = DegToRad(sun.apparent_longitude_deg);
  const double epsilon_rad = DegToRad(sun.true_obliquity_deg);
  const double beta_rad = DegToRad(geocentric_latitude_deg);
  sun.right_ascension_deg = WrapDegrees360(
      RadToDeg(std::atan2(std::sin(lambda_rad) * std::cos(epsilon_rad) - std::tan(beta_rad) * std::sin(epsilon_rad),
                          std::cos(lambda_rad))));
  sun.declination_deg = RadToDeg(std::asin(std::sin(beta_rad) * std::cos(epsilon_rad) +
                                           std::cos(beta_rad) * std::sin(epsilon_rad) * std::sin(lambda_rad)));
  sun.equation_of_equinoxes_deg = sun.nutation_longitude_deg * std::cos(epsilon_rad);
  return sun;
}

double GreenwichMeanSiderealTimeDeg(JulianDate jd_ut1) {
  // Days from J2000 computed from the two parts, so that the large multiplier below does not
  // amplify the rounding of a single 2.4e6 double.
  const double days = (jd_ut1.day - 2451545.0) + jd_ut1.fraction;
  const double jc = days / 36525.0;
  // 360.98564736629 deg/day = 360 deg + 0.98564736629 deg/day; reduce each part separately.
  const double turns = std::fmod(days, 1.0) * 360.0 + 0.98564736629 * days;
  return WrapDegrees360(280.46061837 + turns + jc * jc * (0.000387933 - jc / 38710000.0));
}

SiteTerms MakeSiteTerms(const Site& site) {
  SiteTerms terms;
  terms.latitude_deg = site.latitude_deg();
  terms.longitude_deg = site.longitude_deg();
  terms.sin_latitude = std::sin(site.latitude_rad);
  terms.cos_latitude = std::cos(site.latitude_rad);
  // Observer position on the SPA's reference ellipsoid (flattening 1/298.257, a = 6378140 m).
  constexpr double kAxisRatio = 0.99664719;
  const double u = std::atan(kAxisRatio * std::tan(site.latitude_rad));
  terms.parallax_x = std::cos(u) + site.height_m / 6378140.0 * terms.cos_latitude;
  terms.parallax_y = kAxisRatio * std::sin(u) + site.height_m / 6378140.0 * terms.sin_latitude;
  return terms;
}

SunPosition Topocentric(const SiteTerms& site, double right_ascension_deg, double declination_deg, double distance_au,
                        double apparent_sidereal_time_deg, const SunOptions& options) {
  const double hour_angle_deg = WrapDegrees360(apparent_sidereal_time_deg + site.longitude_deg - right_ascension_deg);

  // Parallax in right ascension and the topocentric declination.
  const double xi_rad = DegToRad(8.794 / (3600.0 * distance_au));  // equatorial horizontal parallax
  const double h_rad = DegToRad(hour_angle_deg);
  const double delta_rad = DegToRad(declination_deg);
  const double sin_xi = std::sin(xi_rad);
  const double denominator = std::cos(delta_rad) - site.parallax_x * sin_xi * std::cos(h_rad);
  const double delta_alpha_rad = std::atan2(-site.parallax_x * sin_xi * std::sin(h_rad), denominator);
  const double delta_prime_rad =
      std::atan2((std::sin(delta_rad) - site.parallax_y * sin_xi) * std::cos(delta_alpha_rad), denominator);
  const double h_prime_rad = h_rad - delta_alpha_rad;

  const double sin_delta_prime = std::sin(delta_prime_rad);
  const double cos_delta_prime = std::cos(delta_prime_rad);
  const double cos_h_prime = std::cos(h_prime_rad);
  const double e0_deg =
      RadToDeg(std::asin(site.sin_latitude * sin_delta_prime + site.cos_latitude * cos_delta_prime * cos_h_prime));

  // Refraction (Bennett-style, scaled by pressure and temperature), applied while any part of
  // the sun's disk can be above the refracted horizon.
  constexpr double kSunRadiusDeg = 0.26667;
  double refraction_deg = 0.0;
  if (options.pressure_hpa > 0.0 && e0_deg >= -(kSunRadiusDeg + options.horizon_refraction_deg)) {
    refraction_deg = (options.pressure_hpa / 1010.0) * (283.0 / (273.0 + options.temperature_c)) * 1.02 /
                     (60.0 * std::tan(DegToRad(e0_deg + 10.3 / (e0_deg + 5.11))));
  }
  const double elevation_deg = e0_deg + refraction_deg;

  // Azimuth from north, eastward: the astronomers' azimuth (from south, westward) + 180.
  const double astronomical_azimuth_rad = std::atan2(
      std::sin(h_prime_rad), cos_h_prime * site.sin_latitude - (sin_delta_prime / cos_delta_prime) * site.cos_latitude);
  const double azimuth_deg = WrapDegrees360(RadToDeg(astronomical_azimuth_rad) + 180.0);

  SunPosition position;
  position.elevation_rad = DegToRad(elevation_deg);
  position.zenith_rad = DegToRad(90.0 - elevation_deg);
  position.azimuth_rad = DegToRad(azimuth_deg);
  position.elevation_geometric_rad = DegToRad(e0_deg);
  position.refraction_rad = DegToRad(refraction_deg);
  position.right_ascension_rad = DegToRad(WrapDegrees360(right_ascension_deg + RadToDeg(delta_alpha_rad)));
  position.declination_rad = delta_prime_rad;
  double h_prime_deg = WrapDegrees360(RadToDeg(h_prime_rad));
  if (h_prime_deg >= 180.0) h_prime_deg -= 360.0;
  position.hour_angle_rad = DegToRad(h_prime_deg);
  position.distance_au = distance_au;
  return position;
}

}  // namespace relume::spa
