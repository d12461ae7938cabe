// Scene frames at a site.
//
// Conventions:
//  - ENU: the local East-North-Up frame at a site (GeographicLib::LocalCartesian): x east,
//    y north, z along the ellipsoid normal, origin at the site, metres. "North" is true
//    (geodetic) north. This is relume's scene frame.
//  - UTM grid: x easting, y northing in metres of one UTM zone, z ellipsoidal height. Its y
//    axis ("grid north") is turned from true north by the meridian convergence gamma, which
//    grows with the distance from the zone's central meridian (up to ~3 deg at 60 N).
//    A mesh stored in UTM coordinates therefore needs the sun's direction rotated by gamma,
//    not just its azimuth copied.
//  - Directions are unit vectors pointing from the scene toward the light (toward the sun).
//  - Directions are exact at the frame's reference point; across a site of size d they vary by
//    about d / 6371 km rad (0.009 deg per km) from the Earth's curvature and, in UTM, from the
//    change of gamma; both are far below the sun's 0.27 deg radius for a site of a few km.
#pragma once

#include <Eigen/Core>
#include <GeographicLib/LocalCartesian.hpp>
#include <optional>

#include "core/site.h"
#include "core/sun/sun_position.h"

namespace relume {

// Unit vector in ENU toward a direction given by azimuth (from north, eastward) and elevation.
Eigen::Vector3d EnuDirectionFromAzimuthElevation(double azimuth_rad, double elevation_rad);

// Unit vector toward the sun in ENU, from its apparent (refracted) elevation: the direction
// light arrives from at the site.
Eigen::Vector3d SunDirectionInEnu(const SunPosition& sun);

// Positions between geodetic coordinates and the ENU frame at a site.
class EnuFrame {
 public:
  explicit EnuFrame(const Site& origin);
  Eigen::Vector3d EnuFromGeodetic(const Site& point) const;
  Site GeodeticFromEnu(const Eigen::Vector3d& point_in_enu) const;
  const Site& origin() const { return origin_; }

 private:
  Site origin_;
  GeographicLib::LocalCartesian local_;
};

// A UTM zone's grid, with its meridian convergence at a reference site (the mesh's origin).
class UtmGridFrame {
 public:
  // zone: 1..60, or nothing for the site's standard zone. Throws InvalidArgumentError when
  // the site is outside UTM's latitude band (84 N .. 80 S) or the zone is invalid.
  explicit UtmGridFrame(const Site& reference, std::optional<int> zone = std::nullopt);

  int zone() const { return zone_; }
  bool northern() const { return northern_; }
  // Meridian convergence at the reference: the bearing of grid north, clockwise from true
  // north, in radians.
  double convergence_rad() const { return convergence_rad_; }
  // Point scale factor at the reference (grid metres per true metre).
  double scale() const { return scale_; }

  // Rotates a direction from ENU into the grid frame (about the up axis by gamma).
  Eigen::Vector3d GridFromEnuDirection(const Eigen::Vector3d& direction_in_enu) const;
  Eigen::Vector3d EnuFromGridDirection(const Eigen::Vector3d& direction_in_grid) const;

  // Positions: easting, northing, height, and back. InvalidArgumentError for a point the grid
  // cannot hold (a northing or easting outside the zone, a latitude outside UTM).
  Eigen::Vector3d GridFromGeodetic(const Site& point) const;
  Site GeodeticFromGrid(const Eigen::Vector3d& point_in_grid) const;

 private:
  int zone_ = 0;
  bool northern_ = true;
  double convergence_rad_ = 0.0;
  double scale_ = 1.0;
};

}  // namespace relume
