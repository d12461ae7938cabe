// The depth measurement model of a structured-light (Kinect v1-like) RGB-D sensor, as pure
// functions: ideal depth (from a TruthSource) -> measured depth in metres with noise,
// quantisation, holes and range limits. Registration of depth into the colour camera, which
// the simulated sensor does as hardware would, is core/depth_registration.h (processing registers
// unregistered recordings with the same function).
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

#include "core/depth_registration.h"
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

}  // namespace relume::sim
