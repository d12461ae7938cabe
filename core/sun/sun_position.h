// The sun's apparent topocentric position, after the NREL Solar Position Algorithm (SPA,
// Reda & Andreas 2004), and the day's sunrise, transit and sunset.
//
// Time scales (see also core/time.h):
//   UTC   what clocks and UtcTime carry.
//   UT1   Earth-rotation time: UT1 = UTC + dut1. |dut1| < 0.9 s, published by the IERS.
//         It sets the sun's hour angle: 1 s of UT1 error is 0.0042 deg of hour angle, so
//         leaving dut1 at 0 can cost up to ~0.004 deg in azimuth and elevation.
//   TT    uniform time for the orbit: TT = UT1 + delta_t (about 69 s in 2025). delta_t only
//         moves the sun along its orbit (0.04 deg/h): 1 s costs about 1e-5 deg.
// When SunOptions::delta_t_s is NaN, the Espenak & Meeus model (core/sun/delta_t.h) is used.
//
// Angles: radians. Azimuth is measured from true (geodetic) north, eastward, in [0, 2 pi).
// Elevation is above the geodetic horizon. "Geometric" values exclude refraction; the plain
// elevation/zenith include it when pressure_hpa > 0. Pressure 0 means no atmosphere.
//
// Accuracy: against ERFA (IAU 2006/2000A, full VSOP-free planetary theory) over 1900-2100 the
// geometric elevation and the cos(elevation)-weighted azimuth agree within 0.0003 deg (see
// docs/sun.md for the measured maximum).
#pragma once

#include <chrono>
#include <limits>
#include <optional>
#include <string>

#include "core/site.h"
#include "core/time.h"

namespace relume {

// Identifies the algorithm in frame metadata and session records.
inline constexpr const char* kSunAlgorithmName = "NREL-SPA-2004";

struct SunOptions {
  // TT - UT1 in seconds; NaN selects DeltaTModelSeconds() for the instant's year.
  double delta_t_s = std::numeric_limits<double>::quiet_NaN();
  // UT1 - UTC in seconds, |dut1| < 1.
  double dut1_s = 0.0;
  // Local air pressure and temperature for refraction. pressure_hpa = 0: no refraction.
  double pressure_hpa = 1013.25;
  double temperature_c = 15.0;
  // Refraction at the horizon, used for the rise/set altitude and the refraction cut-off.
  double horizon_refraction_deg = 0.5667;

  bool IsValid(std::string* why) const;
};

struct SunPosition {
  double elevation_rad = 0.0;            // apparent (refracted when pressure > 0)
  double zenith_rad = 0.0;               // pi/2 - elevation_rad
  double azimuth_rad = 0.0;              // from north, eastward, [0, 2 pi)
  double elevation_geometric_rad = 0.0;  // topocentric, without refraction
  double refraction_rad = 0.0;           // elevation_rad - elevation_geometric_rad
  double right_ascension_rad = 0.0;      // topocentric, [0, 2 pi)
  double declination_rad = 0.0;          // topocentric
  double hour_angle_rad = 0.0;           // topocentric local hour angle, [-pi, pi)
  double distance_au = 0.0;              // Earth-Sun distance
  double delta_t_s = 0.0;                // the delta_t that was used
};

// One SPA evaluation. Throws InvalidArgumentError for an invalid site or options.
SunPosition ComputeSunPosition(const Site& site, UtcTime time, const SunOptions& options = {});

// The same for an instant given as a UT1 Julian date, for dates that UtcTime cannot hold.
// The SPA is valid for the years -2000..6000; outside, throws InvalidArgumentError. delta_t_s
// must be given (NaN is not accepted here: the model is only defined near the present).
SunPosition ComputeSunPositionAtJulianDate(const Site& site, JulianDate jd_ut1, const SunOptions& options);

enum class SunDayKind {
  kNormal,      // the sun rises and sets
  kPolarDay,    // above the horizon all day (midnight sun)
  kPolarNight,  // below the horizon all day
};
const char* ToString(SunDayKind kind);

struct SunDayEvents {
  SunDayKind kind = SunDayKind::kNormal;
  // Events that fall within the local calendar day; absent when they do not happen that day.
  std::optional<UtcTime> sunrise;
  std::optional<UtcTime> transit;
  std::optional<UtcTime> sunset;
  double transit_elevation_rad = 0.0;  // geometric elevation at transit (no refraction)
};

// Sunrise, transit and sunset (SPA appendix A.2, the upper limb at the horizon with
// horizon_refraction_deg of refraction) of the calendar day `local_date` in the zone
// `utc_offset`. The A.2 interpolation is accurate to a few seconds at ordinary latitudes.
SunDayEvents ComputeSunDayEvents(const Site& site, CivilDate local_date, std::chrono::seconds utc_offset,
                                 const SunOptions& options = {});

}  // namespace relume
