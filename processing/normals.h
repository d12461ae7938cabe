// Surface normals from an organised point cloud (a depth map and pinhole intrinsics).
//
// Method: the smooth estimate averages the vertex map over boxes with integral images, in
// the spirit of Holzer et al. 2012: the horizontal tangent is the mean vertex of the box
// right of the pixel minus the mean of the box left of it (rows v - r .. v + r), the vertical
// tangent likewise with boxes below and above; the normal is their cross product. Mean
// vertices of points on a plane stay on that plane, so a plane's normal is exact even with
// holes in the boxes. Where the box touches a depth discontinuity (or holds too few valid
// points) the normal falls back to the cross product of neighbour differences (Ogura & Saito
// eq. 3), taking on each axis the neighbour (forward or backward) whose depth is closer.
// Where neither works the normal is invalid.
//
// Conventions:
//  - Input depth: CV_32FC1, metres along z, NaN/<=0/Inf = hole (processing/depth_filter.h).
//  - Output normals: CV_32FC3, unit, in the camera frame (x right, y down, z forward),
//    facing the camera (n . p < 0 for the surface point p); NaN where invalid.
//  - The vertex of pixel (u, v) is z * ((u + 0.5 - cx) / fx, (v + 0.5 - cy) / fy, 1).
//  - A depth discontinuity between 4-neighbours: |dz| > depth_change_ratio * z, unless the
//    step continues a plane: its step in inverse depth w = 1/z differs from the steps of the
//    pairs before and after it by at most plane_step_tolerance * w (on a plane w is affine in
//    the pixel coordinates). Without that exception every plane seen within ~11 deg of grazing
//    (at 320 px over 60 deg; the ground of a street view) had no normals: 60 % coverage on a
//    level ground plane at eye height, 99 % with it (NormalsTest.GroundSeenAtAGrazingAngle...).
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

#include "core/pinhole.h"

namespace relume::processing {

enum class NormalMethod : unsigned char { kInvalid = 0, kIntegralImage = 1, kNeighbourCross = 2 };

struct NormalOptions {
  int window_radius_px = 3;          // r: boxes are (2 r + 1) x r pixels; 0 = cross product only
  double depth_change_ratio = 0.02;  // |dz| / z above which neighbours are on different surfaces
  double min_valid_fraction = 0.5;   // of each half box, for the smooth estimate
  // A steep step continues a plane when its inverse-depth step is within this many w of its
  // neighbours' (0: never). 1e-4 passes exact planes and planes in whole millimetres to 30 m
  // (99 % and 98 % of a level ground's pixels) and fails curved silhouettes and noisy depth:
  // Kinect-like noise at grazing angles gives normals too poor to relight with. On the random
  // SH suites (relume bench --suite random --stage sh --scenes 60, seed 1, 2026-12-04; no test
  // asserts these) the Kinect p90 relit error was 44.6 % without the exception, 43.9 % at 1e-4,
  // 48.1 % at 5e-4 and 49.0 % at 0.02.
  double plane_step_tolerance = 1e-4;
  bool IsValid(std::string* why) const;
};

struct NormalMap {
  cv::Mat normal_in_camera;  // CV_32FC3, NaN where invalid
  cv::Mat valid;             // CV_8UC1, 255 where the normal is valid
  cv::Mat method;            // CV_8UC1, NormalMethod per pixel
  int integral_count = 0;
  int cross_count = 0;
  int invalid_count = 0;  // pixels with depth but no normal
};

// Throws InvalidArgumentError for bad options, invalid intrinsics or a depth map whose size
// differs from the intrinsics.
NormalMap EstimateNormals(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics,
                          const NormalOptions& options = {});

// The camera-frame vertex map (CV_32FC3, NaN at holes).
cv::Mat VertexMap(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics);

}  // namespace relume::processing
