#include "core/site.h"

#include <cmath>

#include "core/error.h"

namespace relume {

Site Site::FromDegrees(double latitude_deg, double longitude_deg, double height_m) {
  Site site{DegToRad(latitude_deg), DegToRad(longitude_deg), height_m};
  std::string why;
  if (!site.IsValid(&why)) throw InvalidArgumentError("invalid site: " + why);
  return site;
}

bool Site::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (!std::isfinite(latitude_rad) || !std::isfinite(longitude_rad) || !std::isfinite(height_m)) {
    return fail("latitude, longitude and height must be finite numbers");
  }
  // A tiny tolerance lets exactly +-90 / +-180 degrees through after degree->radian rounding.
  constexpr double kTolerance = 1e-12;
  if (std::abs(latitude_rad) > std::numbers::pi / 2 + kTolerance) {
    return fail("latitude " + std::to_string(latitude_deg()) + " deg is outside [-90, 90]");
  }
  if (std::abs(longitude_rad) > std::numbers::pi + kTolerance) {
    return fail("longitude " + std::to_string(longitude_deg()) + " deg is outside [-180, 180]");
  }
  if (height_m < -1000.0 || height_m > 10000.0) {
    return fail("height " + std::to_string(height_m) +
                " m is outside [-1000, 10000] (metres above the WGS84 ellipsoid)");
  }
  return true;
}

}  // namespace relume
