#include "core/frames.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace relume {
namespace {

TEST(FramesTest, AzimuthElevationToEnu) {
  EXPECT_TRUE(EnuDirectionFromAzimuthElevation(0, 0).isApprox(Eigen::Vector3d(0, 1, 0)));
  EXPECT_TRUE(EnuDirectionFromAzimuthElevation(M_PI / 2, 0).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(EnuDirectionFromAzimuthElevation(1.0, M_PI / 2).isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  SunPosition sun;
  sun.azimuth_rad = DegToRad(194.34);
  sun.elevation_rad = DegToRad(39.9);
  EXPECT_NEAR(SunDirectionInEnu(sun).norm(), 1.0, 1e-15);
}

TEST(FramesTest, EnuRoundTrip) {
  const Site origin = Site::FromDegrees(37.9715, 23.7267, 156);
  const EnuFrame frame(origin);
  const Eigen::Vector3d p(120.5, -43.25, 12.0);
  const Site geodetic = frame.GeodeticFromEnu(p);
  EXPECT_TRUE(frame.EnuFromGeodetic(geodetic).isApprox(p, 1e-9));
  EXPECT_NEAR(frame.EnuFromGeodetic(origin).norm(), 0.0, 1e-9);
}

// A point reached from the site along a direction: its UTM displacement must point along
// the direction rotated by the meridian convergence.
void ExpectEnuAndUtmRoutesAgree(const Site& site) {
  const EnuFrame enu(site);
  const UtmGridFrame grid(site);
  for (double azimuth_deg = 0; azimuth_deg < 360; azimuth_deg += 30) {
    const Eigen::Vector3d direction_in_enu = EnuDirectionFromAzimuthElevation(DegToRad(azimuth_deg), DegToRad(25));
    // 50 m along the direction: small enough that curvature is negligible.
    const Site target = enu.GeodeticFromEnu(50.0 * direction_in_enu);
    const Eigen::Vector3d displacement_in_grid = grid.GridFromGeodetic(target) - grid.GridFromGeodetic(site);
    const Eigen::Vector3d expected = grid.GridFromEnuDirection(direction_in_enu);
    const Eigen::Vector2d measured = displacement_in_grid.head<2>().normalized();
    const Eigen::Vector2d predicted = expected.head<2>().normalized();
    const double angle_deg = RadToDeg(std::acos(std::clamp(measured.dot(predicted), -1.0, 1.0)));
    EXPECT_LT(angle_deg, 2e-4) << "azimuth " << azimuth_deg << " at " << site.latitude_deg() << ","
                               << site.longitude_deg() << " gamma " << RadToDeg(grid.convergence_rad());
    EXPECT_TRUE(grid.EnuFromGridDirection(expected).isApprox(direction_in_enu, 1e-12));
  }
}

TEST(FramesTest, EnuAndUtmRoutesAgree) {
  ExpectEnuAndUtmRoutesAgree(Site::FromDegrees(37.9715, 23.7267, 156));  // Athens, 32 km off the meridian
  ExpectEnuAndUtmRoutesAgree(Site::FromDegrees(60.5, 8.9, 700));         // far west in zone 32: |gamma| ~ 2.6 deg
  ExpectEnuAndUtmRoutesAgree(Site::FromDegrees(-33.85, 151.2, 40));      // southern hemisphere
}

TEST(FramesTest, ConvergenceSignAndSize) {
  // East of the central meridian in the northern hemisphere, grid north points east of true
  // north (positive convergence), about dlon * sin(lat).
  const Site east = Site::FromDegrees(45.0, 11.5, 0);  // zone 32, central meridian 9 E
  const UtmGridFrame grid(east);
  EXPECT_EQ(grid.zone(), 32);
  EXPECT_NEAR(RadToDeg(grid.convergence_rad()), 2.5 * std::sin(DegToRad(45.0)), 0.01);
  // True south has grid azimuth 180 deg - gamma.
  const Eigen::Vector3d south_in_grid = grid.GridFromEnuDirection(Eigen::Vector3d(0, -1, 0));
  EXPECT_NEAR(RadToDeg(std::atan2(south_in_grid.x(), south_in_grid.y())), 180.0 - RadToDeg(grid.convergence_rad()),
              1e-9);
}

TEST(FramesTest, UtmRejectsPolarSitesAndBadZones) {
  EXPECT_THROW(UtmGridFrame(Site::FromDegrees(85.0, 0, 0)), InvalidArgumentError);
  EXPECT_THROW(UtmGridFrame(Site::FromDegrees(10.0, 0, 0), 61), InvalidArgumentError);
  EXPECT_NO_THROW(UtmGridFrame(Site::FromDegrees(10.0, 0, 0), 30));  // a neighbouring zone is allowed
}

}  // namespace
}  // namespace relume
