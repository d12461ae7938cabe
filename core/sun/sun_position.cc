#include "core/sun/sun_position.h"

#include <cmath>

#include "core/error.h"
#include "core/sun/delta_t.h"
#include "core/sun/spa.h"

namespace relume {

namespace {

constexpr double kJulianDateOfUnixEpoch = 2440587.5;
constexpr double kSunRadiusDeg = 0.26667;

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

void CheckInputs(const Site& site, const SunOptions& options) {
  std::string why;
  if (!site.IsValid(&why)) throw InvalidArgumentError("sun position: invalid site: " + why);
  if (!options.IsValid(&why)) throw InvalidArgumentError("sun position: invalid options: " + why);
}

JulianDate Ut1FromUtc(UtcTime time, double dut1_s) {
  JulianDate jd = JulianDateFromUtc(time);
  jd.fraction += dut1_s / 86400.0;
  return jd;
}

double ResolveDeltaT(const SunOptions& options, double jd_ut1) {
  if (!std::isnan(options.delta_t_s)) return options.delta_t_s;
  return DeltaTModelSeconds(2000.0 + (jd_ut1 - 2451545.0) / 365.25);
}

SunPosition PositionAt(const Site& site, JulianDate jd_ut1, double delta_t_s, const SunOptions& options) {
  const spa::GeocentricSun sun = spa::ComputeGeocentricSun(jd_ut1.Value() + delta_t_s / 86400.0);
  const double apparent_sidereal_deg = spa::GreenwichMeanSiderealTimeDeg(jd_ut1) + sun.equation_of_equinoxes_deg;
  SunPosition position = spa::Topocentric(spa::MakeSiteTerms(site), sun.right_ascension_deg, sun.declination_deg,
                                          sun.distance_au, apparent_sidereal_deg, options);
  position.delta_t_s = delta_t_s;
  return position;
}

// Difference b - a of two angles in degrees, reduced to (-180, 180]: right ascension wraps
// from 360 to 0 once a year, and its day-to-day change is about 1 deg.
double AngleDifferenceDeg(double b, double a) {
  double d = std::fmod(b - a, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d <= -180.0) d += 360.0;
  return d;
}

double LimitZeroToOne(double value) {
  return value - std::floor(value);
}

// Sunrise/transit/sunset of one UT day (SPA appendix A.2), as fractions of that day.
struct UtDayEvents {
  double transit_day_fraction = 0.0;
  double rise_day_fraction = NAN;  // NaN when the sun does not cross the horizon that day
  double set_day_fraction = NAN;
  double transit_elevation_deg = 0.0;
  double cos_hour_angle_at_horizon = 0.0;  // < -1: polar day, > 1: polar night
};

UtDayEvents EventsOfUtDay(const spa::SiteTerms& site, double jd0_ut, double delta_t_s, const SunOptions& options) {
  // Apparent sidereal time at 0h UT, and the sun's place at 0h TT of the day before, the day
  // and the day after (the paper evaluates these with delta_t = 0).
  const spa::GeocentricSun at_zero_ut = spa::ComputeGeocentricSun(jd0_ut + delta_t_s / 86400.0);
  const double nu = spa::GreenwichMeanSiderealTimeDeg({jd0_ut, 0.0}) + at_zero_ut.equation_of_equinoxes_deg;
  double alpha[3];
  double delta[3];
  for (int i = 0; i < 3; ++i) {
    const spa::GeocentricSun sun = spa::ComputeGeocentricSun(jd0_ut + (i - 1));
    alpha[i] = sun.right_ascension_deg;
    delta[i] = sun.declination_deg;
  }

  UtDayEvents events;
  const double h0_prime = -(kSunRadiusDeg + options.horizon_refraction_deg);
  const double m0 = LimitZeroToOne((alpha[1] - site.longitude_deg - nu) / 360.0);
  const double cos_delta = std::cos(DegToRad(delta[1]));
  events.cos_hour_angle_at_horizon = (std::sin(DegToRad(h0_prime)) - site.sin_latitude * std::sin(DegToRad(delta[1]))) /
                                     (site.cos_latitude * cos_delta);
  const bool crosses = std::abs(events.cos_hour_angle_at_horizon) <= 1.0;
  const double h0_deg = crosses ? RadToDeg(std::acos(events.cos_hour_angle_at_horizon)) : 0.0;
  const double m[3] = {m0, LimitZeroToOne(m0 - h0_deg / 360.0), LimitZeroToOne(m0 + h0_deg / 360.0)};

  const double a_alpha = AngleDifferenceDeg(alpha[1], alpha[0]);
  const double b_alpha = AngleDifferenceDeg(alpha[2], alpha[1]);
  const double a_delta = delta[1] - delta[0];
  const double b_delta = delta[2] - delta[1];
  double h_prime[3];
  double altitude[3];
  double delta_prime[3];
  for (int i = 0; i < 3; ++i) {
    const double nu_i = nu + 360.985647 * m[i];
    const double n = m[i] + delta_t_s / 86400.0;
    const double alpha_prime = alpha[1] + n * (a_alpha + b_alpha + (b_alpha - a_alpha) * n) / 2.0;
    delta_prime[i] = delta[1] + n * (a_delta + b_delta + (b_delta - a_delta) * n) / 2.0;
    h_prime[i] = AngleDifferenceDeg(nu_i + site.longitude_deg - alpha_prime, 0.0);
    altitude[i] =
        RadToDeg(std::asin(site.sin_latitude * std::sin(DegToRad(delta_prime[i])) +
                           site.cos_latitude * std::cos(DegToRad(delta_prime[i])) * std::cos(DegToRad(h_prime[i]))));
  }
  events.transit_day_fraction = m[0] - h_prime[0] / 360.0;
  events.transit_elevation_deg = altitude[0];
  if (crosses) {
    auto corrected = [&](int i) {
      return m[i] + (altitude[i] - h0_prime) / (360.0 * std::cos(DegToRad(delta_prime[i])) * site.cos_latitude *
                                                std::sin(DegToRad(h_prime[i])));
    };
    events.rise_day_fraction = corrected(1);
    events.set_day_fraction = corrected(2);
  }
  return events;
}

}  // namespace

bool SunOptions::IsValid(std::string* why) const {
  if (!std::isnan(delta_t_s) && (!std::isfinite(delta_t_s) || std::abs(delta_t_s) > 8000.0)) {
    return Fail(why, "delta_t must be within +-8000 s (TT - UT1; about 69 s in 2025)");
  }
  if (!std::isfinite(dut1_s) || std::abs(dut1_s) >= 1.0) return Fail(why, "dut1 must be within (-1, 1) s (UT1 - UTC)");
  if (!std::isfinite(pressure_hpa) || pressure_hpa < 0.0 || pressure_hpa > 5000.0) {
    return Fail(why, "pressure must be within [0, 5000] hPa (0 = no atmosphere, no refraction)");
  }
  if (!std::isfinite(temperature_c) || temperature_c < -100.0 || temperature_c > 100.0) {
    return Fail(why, "temperature must be within [-100, 100] deg C");
  }
  if (!std::isfinite(horizon_refraction_deg) || std::abs(horizon_refraction_deg) > 5.0) {
    return Fail(why, "horizon refraction must be within +-5 deg");
  }
  return true;
}

SunPosition ComputeSunPosition(const Site& site, UtcTime time, const SunOptions& options) {
  CheckInputs(site, options);
  const JulianDate jd_ut1 = Ut1FromUtc(time, options.dut1_s);
  return PositionAt(site, jd_ut1, ResolveDeltaT(options, jd_ut1.Value()), options);
}

SunPosition ComputeSunPositionAtJulianDate(const Site& site, JulianDate jd_ut1, const SunOptions& options) {
  CheckInputs(site, options);
  if (std::isnan(options.delta_t_s)) {
    throw InvalidArgumentError("sun position at a Julian date: give delta_t explicitly");
  }
  const double jd = jd_ut1.Value();
  const double first = kJulianDateOfUnixEpoch + static_cast<double>(DaysFromCivil({-2000, 1, 1}));
  const double last = kJulianDateOfUnixEpoch + static_cast<double>(DaysFromCivil({6001, 1, 1}));
  if (!std::isfinite(jd) || jd < first || jd >= last) {
    throw InvalidArgumentError("sun position: Julian date " + std::to_string(jd) +
                               " is outside the SPA's valid years -2000..6000");
  }
  return PositionAt(site, jd_ut1, options.delta_t_s, options);
}

const char* ToString(SunDayKind kind) {
  switch (kind) {
    case SunDayKind::kNormal: return "normal";
    case SunDayKind::kPolarDay: return "polar_day";
    case SunDayKind::kPolarNight: return "polar_night";
  }
  return "unknown";
}

SunDayEvents ComputeSunDayEvents(const Site& site, CivilDate local_date, std::chrono::seconds utc_offset,
                                 const SunOptions& options) {
  CheckInputs(site, options);
  if (local_date.month < 1 || local_date.month > 12 || local_date.day < 1 ||
      local_date.day > DaysInMonth(local_date.year, local_date.month)) {
    throw InvalidArgumentError("sun day events: invalid date");
  }
  if (std::abs(utc_offset.count()) > 18 * 3600) throw InvalidArgumentError("sun day events: UTC offset beyond +-18 h");

  const std::int64_t local_day = DaysFromCivil(local_date);
  const double window_start_s = static_cast<double>(local_day * 86400 - utc_offset.count());
  const double window_end_s = window_start_s + 86400.0;
  const spa::SiteTerms terms = spa::MakeSiteTerms(site);

  SunDayEvents result;
  std::optional<double> kind_indicator;  // cos of the horizon hour angle on the transit's day
  auto to_utc = [&](double unix_day, double fraction) {
    const double seconds = (unix_day + fraction) * 86400.0 - options.dut1_s;
    return UtcTime(std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(seconds)));
  };
  auto in_window = [&](double unix_day, double fraction) {
    const double seconds = (unix_day + fraction) * 86400.0;
    return std::isfinite(seconds) && seconds >= window_start_s && seconds < window_end_s;
  };
  for (std::int64_t d = local_day - 1; d <= local_day + 1; ++d) {
    const double jd0 = kJulianDateOfUnixEpoch + static_cast<double>(d);
    const double unix_day = static_cast<double>(d);
    const UtDayEvents ut = EventsOfUtDay(terms, jd0, ResolveDeltaT(options, jd0), options);
    if (!result.transit && in_window(unix_day, ut.transit_day_fraction)) {
      result.transit = to_utc(unix_day, ut.transit_day_fraction);
      result.transit_elevation_rad = DegToRad(ut.transit_elevation_deg);
      kind_indicator = ut.cos_hour_angle_at_horizon;
    }
    if (!result.sunrise && in_window(unix_day, ut.rise_day_fraction)) {
      result.sunrise = to_utc(unix_day, ut.rise_day_fraction);
    }
    if (!result.sunset && in_window(unix_day, ut.set_day_fraction)) {
      result.sunset = to_utc(unix_day, ut.set_day_fraction);
    }
  }
  if (!result.sunrise && !result.sunset && kind_indicator) {
    if (*kind_indicator < -1.0) result.kind = SunDayKind::kPolarDay;
    if (*kind_indicator > 1.0) result.kind = SunDayKind::kPolarNight;
  }
  return result;
}

}  // namespace relume
