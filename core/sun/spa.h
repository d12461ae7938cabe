// Internal building blocks of the SPA (core/sun/sun_position.h is the public API). They are
// shared by the per-call path and the time-series path (core/sun/sun_track.h), and exposed
// for tests that compare intermediate values with the paper's published example.
//
// Inside this namespace angles are in degrees, as in the paper, and times are Julian dates:
// jd (UT1) for Earth rotation, jde (TT) for the orbit.
#pragma once

#include "core/site.h"
#include "core/sun/sun_position.h"

namespace relume::spa {

// The sun as seen from the Earth's centre: everything that depends on TT only.
struct GeocentricSun {
  double heliocentric_longitude_deg = 0.0;  // L
  double heliocentric_latitude_deg = 0.0;   // B
  double distance_au = 0.0;                 // R
  double nutation_longitude_deg = 0.0;      // delta psi
  double nutation_obliquity_deg = 0.0;      // delta epsilon
  double true_obliquity_deg = 0.0;          // epsilon
  double apparent_longitude_deg = 0.0;      // lambda
  double right_ascension_deg = 0.0;         // alpha, [0, 360)
  double declination_deg = 0.0;             // delta
  // delta psi * cos(epsilon): converts mean into apparent sidereal time.
  double equation_of_equinoxes_deg = 0.0;
};

GeocentricSun ComputeGeocentricSun(double jde_tt);

// Greenwich mean sidereal time (degrees, [0, 360)) for a UT1 Julian date.
double GreenwichMeanSiderealTimeDeg(JulianDate jd_ut1);

// Site quantities that the topocentric step reuses at every instant.
struct SiteTerms {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double sin_latitude = 0.0;
  double cos_latitude = 0.0;
  double parallax_x = 0.0;  // rho cos(phi') of the SPA's observer position
  double parallax_y = 0.0;  // rho sin(phi')
};
SiteTerms MakeSiteTerms(const Site& site);

// The topocentric step: parallax, hour angle, elevation, refraction and azimuth, given the
// geocentric apparent right ascension/declination, distance and apparent sidereal time.
SunPosition Topocentric(const SiteTerms& site, double right_ascension_deg, double declination_deg, double distance_au,
                        double apparent_sidereal_time_deg, const SunOptions& options);

// Reduces an angle in degrees to [0, 360).
double WrapDegrees360(double degrees);

}  // namespace relume::spa
