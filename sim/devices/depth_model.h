// The depth measurement model of a structured-light (Kinect v1-like) RGB-D sensor, as pure
// functions: ideal depth (from a TruthSource) -> measured depth in metres with noise,
// quantisation, holes and range limits; and registration of depth into the colour camera.
//
// Conventions: depth_m is CV_32FC1, metres along the camera's optical axis; NaN is a hole (no
// measurement). Pixel centres at (u + 0.5, v + 0.5) (core/pinhole.h).
//
// The model, in the order it is applied to each pixel:
//  1. Range: depth outside [min_range_m, max_range_m] is a hole.
//  2. Grazing angles: where the angle theta between the surface normal and the viewing ray
//     exceeds max_incidence_rad, the projected pattern is too stretched to match: a hole.
//  3. Depth edges: a pixel whose 4-neighbour differs in depth by more than edge_jump_fraction
//     of its own depth (or is a hole in the truth) is a hole: the projector and the camera see
//     the edge from different places, and block matching fails across it.
//  4. Axial noise, Gaussian with the standard deviation Nguyen, Izadi and Lovell measured on a
//     Kinect v1 ("Modeling Kinect Sensor Noise for Improved 3D Reconstruction and Tracking",
//     3DIMPVT 2012): sigma(z, theta) = a + b (z - z0)^2 + c / sqrt(z) * theta^2 / (pi/2 - theta)^2
//     with a = 1.2 mm, b = 1.9 mm/m^2, z0 = 0.4 m, c = 0.1 mm m^0.5: about 1.9 mm at 1 m and
//     2 cm at 3.5 m facing the sensor, growing steeply towards grazing angles.
//  5. Disparity quantisation: the sensor measures disparity d = f b / z in steps of
//     disparity_step_px (1/8 px on a Kinect v1), so depth steps grow as z^2 / (f b); f is the
//     native disparity image's focal length.
//  6. Output quantisation to depth_step_m (OpenNI delivers millimetres).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>

#include "core/pinhole.h"

namespace relume::sim {

struct DepthModelOptions {
  double min_range_m = 0.5;
  double max_range_m = 4.5;
  double max_incidence_rad = 1.31;  // 75 degrees
  double edge_jump_fraction = 0.05;
  bool noise = true;
  double sigma_base_m = 0.0012;
  double sigma_quadratic_per_m = 0.0019;
  double sigma_reference_depth_m = 0.4;
  double sigma_angle_coefficient = 0.0001;  // m^1.5
  double projector_baseline_m = 0.075;
  double disparity_step_px = 1.0 / 8;  // 0: no disparity quantisation
  // Focal length (pixels) of the sensor's native disparity image; 0: the camera's own fx. A
  // stream scaled down from the native size still has the native disparity steps.
  double disparity_focal_px = 0.0;
  double depth_step_m = 0.001;  // 0: no output quantisation
  bool IsValid(std::string* why) const;
};

// The model's axial standard deviation at depth z and incidence angle theta.
double DepthSigma(double depth_m, double incidence_rad, const DepthModelOptions& options);

// Measured depth from truth depth and normals (sim/truth.h) seen by `camera`; deterministic
// in `seed`. Throws InvalidArgumentError on invalid options or mismatched sizes.
cv::Mat MeasureDepth(const cv::Mat& truth_depth_m, const cv::Mat& normal_in_world, const PinholeCamera& camera,
                     const DepthModelOptions& options, std::uint64_t seed);

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

}  // namespace relume::sim
