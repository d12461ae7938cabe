// A place on Earth where the rig stands.
//
// Conventions: WGS84 geodetic latitude (north positive) and longitude (east positive), in
// radians inside the code; height above the WGS84 ellipsoid in metres (not above the geoid or
// sea level: the two differ by up to ~100 m; the sun's position barely depends on it).
#pragma once

#include <numbers>
#include <string>

namespace relume {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr double kRadPerDeg = std::numbers::pi / 180.0;
constexpr double DegToRad(double deg) {
  return deg * kRadPerDeg;
}
constexpr double RadToDeg(double rad) {
  return rad * kDegPerRad;
}

struct Site {
  double latitude_rad = 0.0;   // [-pi/2, pi/2]
  double longitude_rad = 0.0;  // [-pi, pi], east positive
  double height_m = 0.0;       // ellipsoidal, [-1000, 10000] is accepted

  // Builds a site from degrees and checks it; throws InvalidArgumentError when invalid.
  static Site FromDegrees(double latitude_deg, double longitude_deg, double height_m = 0.0);

  double latitude_deg() const { return RadToDeg(latitude_rad); }
  double longitude_deg() const { return RadToDeg(longitude_rad); }

  // False (with the reason) for NaN, latitude outside +-90 deg, longitude outside +-180 deg,
  // or a height outside [-1000 m, 10000 m].
  bool IsValid(std::string* why) const;
};

}  // namespace relume
