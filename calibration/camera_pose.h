// A camera's pose in the site's ENU frame from ground control points (GCPs): points whose
// position is known (surveyed in ENU, UTM or WGS84) and whose pixel in one of the camera's
// frames the user marked. The intrinsics are given (a chessboard calibration, the scene model,
// or the lens's focal length); the pose is a perspective-n-point solution (OpenCV's
// SOLVEPNP_SQPNP, then Levenberg-Marquardt refinement) with RANSAC against mismarked points.
//
// Conventions: pixels in OpenCV's continuous coordinates with pixel centres at (u + 0.5, v + 0.5)
// as in core/pinhole.h (a GCP file's u, v are such coordinates; a marking tool that puts centres
// at integers needs +0.5). Poses as world_from_camera (core/pinhole.h), world = ENU at the site.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "core/frames.h"
#include "core/pinhole.h"
#include "core/site.h"

namespace relume::calibration {

struct GroundControlPoint {
  std::string name;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  Eigen::Vector3d enu_m = Eigen::Vector3d::Zero();
};

struct CameraPoseOptions {
  double ransac_threshold_px = 3.0;  // a GCP further than this from its reprojection is an outlier
  int min_points = 4;                // at least 4 (P3P's ambiguity needs a fourth)
  std::vector<double> distortion;    // OpenCV (k1, k2, p1, p2[, k3]); empty: none
  bool IsValid(std::string* why) const;
};

struct CameraPoseResult {
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  double rms_px = 0.0;              // over the inliers
  std::vector<double> residual_px;  // per GCP, in the input's order
  std::vector<bool> inlier;         // per GCP
  int inliers = 0;
  std::string Report(const std::vector<GroundControlPoint>& points) const;  // one line per GCP
};

// Throws InvalidArgumentError when there are fewer than min_points GCPs (or inliers), when the
// points are degenerate (all on one line) or when no pose puts them in front of the camera.
CameraPoseResult EstimateCameraPose(const std::vector<GroundControlPoint>& points, const PinholeIntrinsics& intrinsics,
                                    const CameraPoseOptions& options = {});

// Surveyed coordinates (a, b, c) to ENU at `site`, per `frame`: "enu" east, north, up (m); "utm"
// easting, northing, ellipsoidal height (m, in `zone`, 0 = the site's); "wgs84" latitude (deg),
// longitude (deg), ellipsoidal height (m); through geodetic coordinates (GeographicLib).
class SurveyFrame {
 public:
  // InvalidArgumentError for a frame other than enu, utm, wgs84.
  SurveyFrame(const std::string& frame, const Site& site, int zone = 0);
  // InvalidArgumentError for coordinates outside the frame's domain.
  Eigen::Vector3d ToEnu(const Eigen::Vector3d& abc) const;
  const std::string& name() const { return frame_; }

 private:
  std::string frame_;
  EnuFrame enu_;
  std::optional<UtmGridFrame> grid_;
};

// A finite number filling one CSV cell (spaces around it allowed), for the survey files here and
// in markers.h.
bool ParseCsvNumber(const std::string& text, double* value);

// A GCP file: CSV with a header, one point per line: `name,u,v,a,b,c` where (a, b, c) are, per
// `frame`: "enu" east, north, up (m); "utm" easting, northing, ellipsoidal height (m, in `zone`,
// 0 = the site's); "wgs84" latitude (deg), longitude (deg), ellipsoidal height (m). Converted to
// ENU at `site` through geodetic coordinates (GeographicLib). ConfigError naming the line.
std::vector<GroundControlPoint> LoadGcpFile(const std::string& path, const std::string& frame, const Site& site,
                                            int zone = 0);

}  // namespace relume::calibration
