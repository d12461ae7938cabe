// Registration of depth into a colour camera: the depth image of an RGB-D sensor, whose depth
// camera sits at color_from_depth from its colour camera, resampled so that each colour pixel
// holds the depth of what it sees. Sensors with hardware registration do this themselves (the
// simulated sensor models them with this function); recordings without it are registered by
// processing (pipeline/sh_pipeline.cc) from the session's rgbd_geometry row.
//
// Conventions: depth in metres along each camera's optical axis (CV_32FC1), NaN = no depth;
// pixel centres at (u + 0.5, v + 0.5) (core/pinhole.h); color_from_depth maps points in the
// depth camera's frame to the colour camera's.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "core/pinhole.h"

namespace relume {

// How depth is resampled into the colour camera.
enum class Registration {
  // What OpenNI2 / PrimeSense hardware registration does: each depth pixel is lifted to 3D,
  // moved by color_from_depth, and written at the colour pixel it projects into, keeping the
  // nearest surface (z-buffer). The stored point is up to half a pixel off the colour pixel's
  // ray, and where the two fields of view differ (58 vs 62.5 deg) two depth pixels share a
  // colour pixel every ~11 columns (on a sphere 1.8 m away the error against the colour
  // camera's own depth is median 1.5 mm: depth_model_test.cc).
  kNearest,
  // Then, per colour pixel, the depth surface is intersected with the pixel's own ray: the
  // point is moved into the depth image, the depth bilinearly interpolated there, and the
  // colour ray's depth updated until it moves by less than 1e-7 m (2-3 steps). Next to an edge
  // (a sample more than edge_jump_fraction behind the nearest one) or a hole, only the samples
  // on the nearest surface are interpolated; where they carry under a quarter of the weight,
  // or the steps do not converge, the nearest value stays. For ideal (noise-free) simulated
  // sensors.
  kInterpolated,
};

// Resamples depth into the colour camera (see Registration). Colour pixels nothing projects
// into are holes (NaN). The result holds the colour camera's z.
cv::Mat RegisterDepthToColor(const cv::Mat& depth_m, const PinholeIntrinsics& depth_intrinsics,
                             const PinholeIntrinsics& color_intrinsics, const Eigen::Isometry3d& color_from_depth,
                             Registration method = Registration::kNearest, double edge_jump_fraction = 0.05);

}  // namespace relume
