// An independent reference for the sun's apparent topocentric position, built on ERFA
// (the open-licence copy of the IAU's SOFA library): the Earth's barycentric and heliocentric
// state from eraEpv00, light time, annual aberration (eraAb), the IAU 2006/2000A
// celestial-to-terrestrial matrix (eraC2t06a, which includes precession, nutation, Earth
// rotation angle), and the observer on the WGS84 ellipsoid (eraGd2gc). Polar motion and
// diurnal aberration (<= 0.32 arcsec) are left out, as in the SPA. No refraction.
//
// Used by tests and benchmarks only; relume's runtime uses the SPA.
#pragma once

#include "core/site.h"
#include "core/time.h"

namespace relume::testing {

struct ErfaSunPosition {
  double elevation_rad = 0.0;  // geometric (no refraction)
  double azimuth_rad = 0.0;    // from north, eastward, [0, 2 pi)
  double distance_au = 0.0;    // observer to sun
};

ErfaSunPosition ErfaTopocentricSun(const Site& site, JulianDate jd_ut1, double delta_t_s);

}  // namespace relume::testing
