// Surface normals from an organised point cloud (a depth map and pinhole intrinsics).
//
// Method: the smooth estimate averages the vertex map over boxes with integral images, in
// the spirit of Holzer et al. 2012: the horizontal tangent is the mean vertex of the box
// right of the pixel minus the mean of the box left of it (rows v - r .. v + r), the vertical
// tangent likewise with boxes below and above; the normal is their cross product. Mean
// vertices of points on a plane stay on that plane, so a plane's normal is exact even with
// holes in the boxes. Where the box touches a depth discontinuity, the image border or holds
// too few valid points, smaller centred boxes are tried, down to min_window_radius_px (a pixel
// 2 px from a silhouette gets a 5 x 2 box instead of a one-pixel difference). Where none fits,
// the normal falls back to the cross product of neighbour differences (Ogura & Saito eq. 3),
// taking on each axis the neighbour (forward or backward) whose depth is closer; on noisy depth
// (below) first to the mean tangents of the 3 x 3 boxes centred on the pixel's 8 neighbours
// that hold no discontinuity. Where nothing works the normal is invalid.
//
// Jets (jet_radius_px), on depth without noise. Beside a silhouette the smaller boxes and the
// one-pixel differences are secants: a sphere's limb, whose depth changes as the square root of
// the distance to it, comes out tens of degrees less grazing than it is. There the pixel's
// normal is refined by an osculating jet (Cazals & Pouget 2003): a quadratic height field
// h = c0 + c1 s + c2 t + c3 s^2 + c4 s t + c5 t^2 fitted by least squares to the vertices of the
// pixel's own surface within jet_radius_px (those its 4-neighbour links reach without crossing a
// discontinuity), in the tangent frame of the current normal, which becomes n - c1 e_s - c2 e_t;
// twice, the second time in the first's frame. Exact on planes and quadrics seen as height
// fields; kept only when the fit's RMS residual is at most jet_max_residual of the points' RMS
// distance to the pixel (two faces of a box are not one quadric) and it has at least 10 points.
// Not on noisy depth: six unknowns from ~20 noisy points follow the noise. Random SH suites
// (2026-12-07, one-off runs no test repeats), non-negative light, median / p90, 60 scenes of
// seed 1: exact depth 2.60 / 5.17 -> 2.04 / 4.80 %, smooth lights 1.55 / 2.87 -> 1.25 / 2.69 %;
// 30 scenes of seed 7: 2.45 / 4.50 -> 2.09 / 4.17 %, 1.44 / 3.16 -> 1.19 / 2.70 %. Radius 3
// gave 2.21 % on the first 20 scenes (radius 2: 2.04 %); residual bounds 0.003 and 0.03 the
// same as 0.01 within 0.01 point.
//
// Noisy depth. The fine-scale estimates (the crease refinement's 3 x 3 plane fits and one-pixel
// differences) are exact on depth without noise and follow the noise on sensor depth: with
// Kinect-like noise (~1.9 mm at 1 m, 3.6 mm pixels at 320 px over 60 deg) a one-pixel
// difference is tens of degrees off. The depth counts as noisy when the caller says so
// (depth_noisy: the SH geometry step's filtered depth) or when it measures noisy
// (EstimateDepthNoise, refine_creases_below_noise_at_1m_m). On noisy depth creases are not
// refined, no jets are fitted (below) and the neighbours' boxes replace one-pixel differences
// where they can.
// Random SH suites (relume bench --suite random --stage sh, 2026-12-07, one-off runs that no
// test repeats), non-negative light, median / p90 relit error, 60 scenes of seed 1:
//  - Kinect-like depth: 9.32 / 17.7 % -> 7.98 / 13.4 % with the smaller boxes -> 7.45 / 12.5 %
//    with the neighbours' boxes too (30 scenes of seed 7: 8.82 -> 7.10 -> 6.57 % median);
//  - exact depth (the smaller boxes only): 2.62 / 5.57 -> 2.60 / 5.17 %, smooth lights 1.72 /
//    3.05 -> 1.55 / 2.87 %. The neighbours' boxes on exact depth were worse (20 scenes: 2.70
//    -> 3.41 %): there a one-pixel difference is exact and a neighbour's box is a pixel off on
//    curved surfaces.
//  - Larger windows do not help noisy depth: radius 5 / 8 with the smaller boxes gave Kinect
//    p90 37.9 / 41.4 % (20 scenes; 26.7 % at 3): they blend more pixels across creases.
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
//
// Creases (refine_creases). Where two planes meet (a box's edge) depth is continuous, so the
// boxes of every pixel within r of the crease hold both planes and blend their normals. On the
// random SH suites' exact depth, pixels within 2 px of a crease carried 55-57 % of the relit
// squared error (median scene; a one-off diagnostic of 2026-12-05, no test repeats it). The
// refinement: a pixel within r of a kink (inverse depth's second difference along a row or
// column above plane_step_tolerance w, and at least twice those 2 px either side: a crease,
// not a smoothly curved surface) whose centred (2 r + 1)^2
// box is not planar (plane-fit variance along the normal above kCreasePlanarity times the
// variance within the plane) takes the normal of the most planar of the 8 boxes of 3 x 3
// pixels that have it on their border and hold no discontinuity, when that box is kCreaseGain
// times more planar than the centred one: a box on the pixel's own face. Three
// boxes in different orientations at 0.9-1.1 m (NormalsTest.CreasesKeepEachFacesNormal): mean
// error within 3 px of their creases 19.5 -> 0.54 deg, p95 72.8 -> 0.89 deg. Cost at 640x480 on
// exact depth (sh_benchmark BM_Normals): 21 -> 30 ms.
// 3 x 3 fits need depth without noise (rendered depth, a mesh's, depth judged noise-free): on
// noisy depth they follow the noise, so the SH geometry step turns the refinement off whenever
// it filters depth (on the Kinect-noise suite, filtered, it raised the p90 relit error from
// 43.9 % to about 46 % in trials that no test repeats). Noisy depth also makes nearly every
// pixel a kink candidate (13-30 % of the pixels are kinks at 0.05-2 mm of noise or in whole
// millimetres, against 5-15 % on the suites' exact depth, so their share cannot tell), and the
// plane fits then cost 50x the estimate: 1.15 s against 23 ms for a 640x480 plane with 2 mm
// of noise (2026-12-05). So EstimateNormals first measures the depth's own noise
// (EstimateDepthNoise, ~12 ms at 640x480) and refines only depth NoiseFree below
// refine_creases_below_noise_at_1m_m; 0 skips the measurement, for a caller that has judged
// the depth noise-free already (the SH geometry step, which measured its stream's first frame).
#pragma once

#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>

#include "core/pinhole.h"
#include "processing/depth_filter.h"

namespace relume::processing {

enum class NormalMethod : unsigned char {
  kInvalid = 0,
  kIntegralImage = 1,
  kNeighbourCross = 2,
  kCreaseBox = 3,       // a 3 x 3 box beside a crease (refine_creases)
  kNeighbourBoxes = 4,  // the neighbours' 3 x 3 boxes, on noisy depth (neighbour_boxes_on_noisy_depth)
  kJet = 5,             // an osculating jet beside a discontinuity, on depth without noise (jet_radius_px)
};

struct NormalOptions {
  int window_radius_px = 3;  // r: boxes are (2 r + 1) x r pixels; 0 = cross product only
  // Where the r box does not fit, centred boxes of radius r - 1 down to this (clamped to r) are
  // tried before the fallback; r: straight to the fallback (the estimate before 2026-12-07).
  int min_window_radius_px = 1;
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
  bool refine_creases = true;  // see "Creases" above; for depth without noise
  // With refine_creases: refine only when the depth measures NoiseFree below this (at 1 m, the
  // SH pipeline's denoise rule); 0 = refine without measuring (the caller knows the depth is
  // noise-free). See "Creases" above.
  // The same measurement decides neighbour_boxes_on_noisy_depth and jet_radius_px (MeasuresNoise).
  double refine_creases_below_noise_at_1m_m = kDenoiseSkipBelowAt1mM;
  // On noisy depth, before the one-pixel cross product: the mean tangents of the neighbours'
  // edge-free 3 x 3 boxes (see "Noisy depth" above).
  bool neighbour_boxes_on_noisy_depth = true;
  // On depth without noise, pixels whose window box does not fit: the normal of an osculating
  // jet over the pixel's surface within this radius (see "Jets" above); 0 = off.
  int jet_radius_px = 2;
  double jet_max_residual = 0.01;  // of the points' RMS distance to the pixel
  // The caller knows the depth is noisy (the SH geometry step filters only depth that measured
  // noisy): no measurement, no crease refinement or jets, neighbour boxes.
  bool depth_noisy = false;
  // Whether the estimate measures the depth's noise: a choice depends on it, and neither
  // depth_noisy nor a threshold of 0 has decided it.
  bool MeasuresNoise() const {
    return !depth_noisy && refine_creases_below_noise_at_1m_m > 0.0 && window_radius_px > 0 &&
           (refine_creases || neighbour_boxes_on_noisy_depth || jet_radius_px > 0);
  }
  static constexpr double kCreasePlanarity = 0.001;
  static constexpr double kCreaseGain = 20.0;
  bool IsValid(std::string* why) const;
};

struct NormalMap {
  cv::Mat normal_in_camera;  // CV_32FC3, NaN where invalid
  cv::Mat valid;             // CV_8UC1, 255 where the normal is valid
  cv::Mat method;            // CV_8UC1, NormalMethod per pixel
  int integral_count = 0;    // a centred box: the window's, or a smaller one beside a discontinuity
  int cross_count = 0;
  int crease_count = 0;         // refined beside a crease (not in integral_count)
  int neighbour_box_count = 0;  // the neighbours' boxes, on noisy depth (not in cross_count)
  int jet_count = 0;            // refined by a jet (not in integral_count or cross_count)
  int invalid_count = 0;        // pixels with depth but no normal
  // refine_creases asked for, but the depth measured noisy (refine_creases_below_noise_at_1m_m):
  // no pixel refined; the measurement says how noisy.
  std::optional<DepthNoiseEstimate> creases_skipped_for_noise;
};

// Throws InvalidArgumentError for bad options, invalid intrinsics or a depth map whose size
// differs from the intrinsics.
NormalMap EstimateNormals(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics,
                          const NormalOptions& options = {});

// The camera-frame vertex map (CV_32FC3, NaN at holes).
cv::Mat VertexMap(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics);

}  // namespace relume::processing
