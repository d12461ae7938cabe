// The transform from an RGB-D sensor's depth camera to its colour camera (color_from_depth,
// drivers/frame.h), from frames of a ChArUco board that both cameras see. The colour camera
// gives the board's pose (its identified corners, perspective-n-point with the colour
// intrinsics), the depth camera the board's plane (a robust fit to the depth points inside the
// board's outline). With three or more views of the board at different tilts, the rotation is the
// one that turns the depth planes' normals into the colour planes' (Kabsch), and the translation
// the one that makes their distances agree in least squares: plane-to-plane calibration
// (Unnikrishnan and Hebert, "Fast extrinsic calibration of a laser rangefinder to a camera",
// CMU-RI-TR-05-09, 2005). No IR image is needed, so it works on what an RGB-D session records.
//
// Conventions: color_from_depth maps points in the depth camera's frame to the colour camera's;
// depth in metres along the depth camera's axis, NaN = none (core/depth_registration.h).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calibration/intrinsics.h"
#include "core/pinhole.h"

namespace relume::calibration {

struct RgbdExtrinsicsOptions {
  CharucoOptions board;
  int min_views = 3;
  // The views' board normals (in the colour camera) must spread at least this far from their
  // mean, or the translation along the normals' common direction is not determined.
  double min_normal_spread_deg = 10.0;
  // Depth points further than this from a view's plane are outliers (the board's edge, noise).
  double plane_inlier_m = 0.01;
  // The board's outline is shrunk by this fraction of its size before depth points are taken,
  // so that an initial transform a few centimetres off still picks points on the board.
  double outline_margin_fraction = 0.15;
  int iterations = 3;  // outline from the current estimate, planes, transform; repeated
  bool IsValid(std::string* why) const;
};

struct RgbdExtrinsicsResult {
  Eigen::Isometry3d color_from_depth = Eigen::Isometry3d::Identity();
  std::vector<int> views_used;           // indices into the frames given
  std::vector<int> views_without_board;  // too few board corners in colour, or no plane in depth
  std::vector<double> view_plane_rms_m;  // per view used: depth inliers' RMS distance to their plane
  std::vector<double> view_normal_deg;   // per view used: angle between R n_depth and n_colour
  std::vector<double> view_distance_m;   // per view used: residual of the plane distance
  double normal_spread_deg = 0.0;
  std::string Report() const;
};

// `colour`: 8-bit grey or RGB frames of the colour camera; `depth`: the depth frames taken with
// them (CV_32FC1 metres, the depth camera's size); `initial`: the transform to start from (the
// sensor's nominal one, or the identity). Throws InvalidArgumentError naming what is missing: too
// few usable views, boards all at one tilt, mismatched sizes.
RgbdExtrinsicsResult CalibrateRgbdExtrinsics(const std::vector<cv::Mat>& colour, const std::vector<cv::Mat>& depth,
                                             const PinholeIntrinsics& colour_intrinsics,
                                             const PinholeIntrinsics& depth_intrinsics,
                                             const Eigen::Isometry3d& initial, const RgbdExtrinsicsOptions& options);

}  // namespace relume::calibration
