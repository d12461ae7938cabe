#include "core/frames.h"

#include <GeographicLib/UTMUPS.hpp>
#include <cmath>

#include "core/error.h"

namespace relume {

Eigen::Vector3d EnuDirectionFromAzimuthElevation(double azimuth_rad, double elevation_rad) {
  const double horizontal = std::cos(elevation_rad);
  return {horizontal * std::sin(azimuth_rad), horizontal * std::cos(azimuth_rad), std::sin(elevation_rad)};
}

Eigen::Vector3d SunDirectionInEnu(const SunPosition& sun) {
  return EnuDirectionFromAzimuthElevation(sun.azimuth_rad, sun.elevation_rad);
}

EnuFrame::EnuFrame(const Site& origin)
    : origin_(origin), local_(origin.latitude_deg(), origin.longitude_deg(), origin.height_m) {}

Eigen::Vector3d EnuFrame::EnuFromGeodetic(const Site& point) const {
  Eigen::Vector3d enu;
  local_.Forward(point.latitude_deg(), point.longitude_deg(), point.height_m, enu.x(), enu.y(), enu.z());
  return enu;
}

Site EnuFrame::GeodeticFromEnu(const Eigen::Vector3d& p) const {
  double lat_deg = 0.0, lon_deg = 0.0, height_m = 0.0;
  local_.Reverse(p.x(), p.y(), p.z(), lat_deg, lon_deg, height_m);
  return Site{DegToRad(lat_deg), DegToRad(lon_deg), height_m};
}

UtmGridFrame::UtmGridFrame(const Site& reference, std::optional<int> zone) {
  std::string why;
  if (!reference.IsValid(&why)) throw InvalidArgumentError("UTM grid: invalid reference site: " + why);
  const double lat = reference.latitude_deg();
  if (lat > 84.0 || lat < -80.0) {
    throw InvalidArgumentError("UTM grid: latitude " + std::to_string(lat) +
                               " deg is outside UTM's band (80 S .. 84 N); use a polar (UPS) or local frame");
  }
  if (zone && (*zone < 1 || *zone > 60)) {
    throw InvalidArgumentError("UTM grid: zone " + std::to_string(*zone) + " is not in 1..60");
  }
  double x = 0.0, y = 0.0, gamma_deg = 0.0, k = 1.0;
  const int setzone = zone ? *zone : GeographicLib::UTMUPS::STANDARD;
  try {
    GeographicLib::UTMUPS::Forward(lat, reference.longitude_deg(), zone_, northern_, x, y, gamma_deg, k, setzone);
  } catch (const GeographicLib::GeographicErr& e) {
    throw InvalidArgumentError(std::string("UTM grid: ") + e.what());
  }
  convergence_rad_ = DegToRad(gamma_deg);
  scale_ = k;
}

// A direction with true azimuth A has grid azimuth A - gamma: a counter-clockwise (seen from
// above) rotation of the vector by gamma about up.
Eigen::Vector3d UtmGridFrame::GridFromEnuDirection(const Eigen::Vector3d& d) const {
  const double c = std::cos(convergence_rad_);
  const double s = std::sin(convergence_rad_);
  return {c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z()};
}

Eigen::Vector3d UtmGridFrame::EnuFromGridDirection(const Eigen::Vector3d& d) const {
  const double c = std::cos(convergence_rad_);
  const double s = std::sin(convergence_rad_);
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z()};
}

Eigen::Vector3d UtmGridFrame::GridFromGeodetic(const Site& point) const {
  int zone = 0;
  bool northern = true;
  double x = 0.0, y = 0.0;
  try {
    GeographicLib::UTMUPS::Forward(point.latitude_deg(), point.longitude_deg(), zone, northern, x, y, zone_);
  } catch (const GeographicLib::GeographicErr& e) {
    throw InvalidArgumentError(std::string("UTM grid: ") + e.what());
  }
  if (northern != northern_) {
    // Keep one hemisphere's northing convention across the equator.
    y += northern_ ? -10'000'000.0 : 10'000'000.0;
  }
  return {x, y, point.height_m};
}

Site UtmGridFrame::GeodeticFromGrid(const Eigen::Vector3d& p) const {
  double lat_deg = 0.0, lon_deg = 0.0;
  try {
    GeographicLib::UTMUPS::Reverse(zone_, northern_, p.x(), p.y(), lat_deg, lon_deg);
  } catch (const GeographicLib::GeographicErr& e) {
    // An easting or northing outside the zone: a mesh or offset that is not in this grid.
    throw InvalidArgumentError(std::string("UTM grid: zone ") + std::to_string(zone_) + (northern_ ? "N" : "S") + ": " +
                               e.what());
  }
  return Site{DegToRad(lat_deg), DegToRad(lon_deg), p.z()};
}

}  // namespace relume
