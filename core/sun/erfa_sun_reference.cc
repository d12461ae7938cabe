#include "core/sun/erfa_sun_reference.h"

#include <erfa.h>
#include <erfam.h>

#include <cmath>
#include <numbers>

namespace relume::testing {

ErfaSunPosition ErfaTopocentricSun(const Site& site, JulianDate jd_ut1, double delta_t_s) {
  const double tt1 = jd_ut1.day;
  const double tt2 = jd_ut1.fraction + delta_t_s / 86400.0;

  // Earth's heliocentric and barycentric position (au) and velocity (au/day), BCRS axes.
  // TT is used for TDB: they differ by < 2 ms.
  double pvh[2][3];
  double pvb[2][3];
  eraEpv00(tt1, tt2, pvh, pvb);

  // Geocentric position of the sun when the light left it: the sun's barycentric position
  // moved back by the light time, minus the Earth's barycentric position now.
  constexpr double kSpeedOfLightAuPerDay = ERFA_CMPS * ERFA_DAYSEC / ERFA_DAU;
  double sun_velocity[3];
  for (int i = 0; i < 3; ++i) sun_velocity[i] = pvb[1][i] - pvh[1][i];
  double geocentric[3];
  for (int i = 0; i < 3; ++i) geocentric[i] = -pvh[0][i];
  for (int iteration = 0; iteration < 2; ++iteration) {
    const double light_time_days = eraPm(geocentric) / kSpeedOfLightAuPerDay;
    for (int i = 0; i < 3; ++i) geocentric[i] = -pvh[0][i] - light_time_days * sun_velocity[i];
  }
  double distance_au = 0.0;
  double natural[3];
  eraPn(geocentric, &distance_au, natural);

  // Annual aberration from the Earth's barycentric velocity.
  double v[3];
  for (int i = 0; i < 3; ++i) v[i] = pvb[1][i] / kSpeedOfLightAuPerDay;
  const double bm1 = std::sqrt(1.0 - eraPm(v) * eraPm(v));
  double proper[3];
  eraAb(natural, v, distance_au, bm1, proper);

  // GCRS -> ITRS (no polar motion), then the topocentric vector in metres.
  double c2t[3][3];
  eraC2t06a(tt1, tt2, jd_ut1.day, jd_ut1.fraction, 0.0, 0.0, c2t);
  double direction_itrs[3];
  eraRxp(c2t, proper, direction_itrs);
  double observer_m[3];
  eraGd2gc(ERFA_WGS84, site.longitude_rad, site.latitude_rad, site.height_m, observer_m);
  double topocentric[3];
  for (int i = 0; i < 3; ++i) topocentric[i] = direction_itrs[i] * distance_au * ERFA_DAU - observer_m[i];

  // Into the local East-North-Up frame.
  const double sl = std::sin(site.longitude_rad), cl = std::cos(site.longitude_rad);
  const double sp = std::sin(site.latitude_rad), cp = std::cos(site.latitude_rad);
  const double east = -sl * topocentric[0] + cl * topocentric[1];
  const double north = -sp * cl * topocentric[0] - sp * sl * topocentric[1] + cp * topocentric[2];
  const double up = cp * cl * topocentric[0] + cp * sl * topocentric[1] + sp * topocentric[2];

  ErfaSunPosition result;
  result.elevation_rad = std::atan2(up, std::hypot(east, north));
  double azimuth = std::atan2(east, north);
  if (azimuth < 0.0) azimuth += 2.0 * std::numbers::pi;
  result.azimuth_rad = azimuth;
  result.distance_au = std::sqrt(east * east + north * north + up * up) / ERFA_DAU;
  return result;
}

}  // namespace relume::testing
