// Cast shadows within an RGB-D frame: the surface points a distant light cannot reach because
// other surfaces the depth image shows stand in its way, found by marching from each point
// toward the light through the depth image (screen-space ray marching), and how much of the SH
// model's irradiance they remove. The SH model has no visibility term (sh.h): where a fitted
// light is directional and the scene shadows itself, the fit and every ratio relit from it are
// off by about that much, whatever the normals (docs/processing-sh.md).
//
// Conventions:
//  - The light's direction is the luminance of the fitted light's order-1 band (x, y, z =
//    coefficients 3, 1, 2), in the camera frame (x right, y down, z forward), pointing toward
//    the light. A distant light of irradiance E_d along d has order-1 coefficients 0.4886 E_d d
//    and adds E_d max(0, n . d) to E(n): E_d is taken as |L1| / 0.4886 (a lower bound when
//    several lights spread the band).
//  - A ray from the point P (lifted by `surface_bias_m` along its normal) is occluded when a
//    sample Q on it projects onto a pixel whose depth is nearer the camera than Q by more than
//    the tolerance (`depth_tolerance_m` + `depth_tolerance_per_m` Q.z) and by less than
//    max(`thickness_m`, `thickness_per_m` Q.z) (further behind, the ray passes behind the
//    surface). The ray goes max(`max_distance_m`, `max_distance_per_m` P.z) in `steps` equal
//    steps. Samples leaving the
//    image or reaching pixels without depth end the ray unoccluded: occluders the camera does
//    not see are missed, so the estimate is a lower bound.
//  - The removed share at a shadowed pixel is E_d max(0, n . d) / E_sh(n) (luminance); the
//    estimate's figure is its RMS over every masked pixel (unshadowed pixels count as 0).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <string>

#include "core/image.h"
#include "core/pinhole.h"
#include "processing/sh.h"

namespace relume::processing {

struct CastShadowOptions {
  double max_distance_m = 1.5;  // how far toward the light a ray is followed
  int steps = 48;               // samples along it (evenly spaced)
  double surface_bias_m = 0.01;
  double depth_tolerance_m = 0.005;
  double depth_tolerance_per_m = 0.01;  // grows with distance, as depth noise does
  double thickness_m = 0.5;
  // Scenes larger than a table top: a ray goes at least max_distance_per_m times its point's
  // depth, and an occluder stands up to thickness_per_m times the sample's depth (at least
  // thickness_m) in front of it (a building 30 m away hides the sun from a wall behind it).
  double max_distance_per_m = 1.0;
  double thickness_per_m = 0.2;
  // EstimateShadowsToward: pixels facing the light at least this much (n . d) are assessed, and
  // each side (lit, shadowed) needs min_evidence_pixels for a contrast.
  double min_facing = 0.25;
  int min_evidence_pixels = 10;
  // Below this directional share of the irradiance at the light's direction, the light is
  // taken as diffuse and no ray is marched (nothing to shadow).
  double min_directional_share = 0.05;

  bool IsValid(std::string* why) const;
};

struct CastShadowEstimate {
  Eigen::Vector3d light_direction = Eigen::Vector3d::Zero();  // camera frame, toward the light
  double directional_irradiance = 0.0;                        // E_d (luminance, the light's units)
  double directional_share = 0.0;                             // E_d / E_sh(d): how directional the fitted light is
  int facing_pixels = 0;                                      // masked pixels with n . d > 0
  int shadowed_pixels = 0;                                    // of those, occluded toward the light
  double removed_share_rms = 0.0;  // RMS over masked pixels of E_d max(0, n . d) / E_sh(n) where shadowed
  bool marched = false;            // false: the light is too diffuse to cast shadows

  double shadowed_fraction() const {
    return facing_pixels > 0 ? static_cast<double>(shadowed_pixels) / facing_pixels : 0.0;
  }
  std::string Describe() const;
};

// depth_m: CV_32FC1 metres along the optical axis (NaN: none); normals: CV_32FC3 unit normals in
// the camera frame; mask: CV_8UC1, the pixels to assess (non-zero). All the same size as
// `intrinsics`. Throws InvalidArgumentError for mismatched inputs or invalid options.
CastShadowEstimate EstimateCastShadows(const cv::Mat& depth_m, const cv::Mat& normals, const cv::Mat& mask,
                                       const PinholeIntrinsics& intrinsics, const ShRgb& light,
                                       const CastShadowOptions& options = {});

// Shadows toward a light whose direction is known without the fit (the sun, from the session's
// ephemeris and the camera's pose), and whether the image shows them. The fitted light cannot
// be asked: with unknown albedo, segments of one colour split into sunlit and shadowed ones, their
// albedos absorb the sun, and the fit is mostly ambient with a small residual (the demo's
// outdoor stream). The pixels facing the light (n . d >= min_facing) are split into occluded and
// not; the ratio of their median luminances is the evidence: several times 1 under a shining
// sun, near 1 under an overcast sky (albedo differences between the two groups blur it).
struct DirectionalShadowEvidence {
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();  // camera frame, toward the light
  int facing_pixels = 0;
  int shadowed_pixels = 0;
  double lit_luminance_median = std::numeric_limits<double>::quiet_NaN();
  double shadowed_luminance_median = std::numeric_limits<double>::quiet_NaN();
  // lit / shadowed median luminance; NaN when either side has fewer than min_evidence_pixels.
  double contrast = std::numeric_limits<double>::quiet_NaN();

  double shadowed_fraction() const {
    return facing_pixels > 0 ? static_cast<double>(shadowed_pixels) / facing_pixels : 0.0;
  }
  std::string Describe() const;
};

// As EstimateCastShadows, with the light's direction (camera frame, need not be unit) and the
// frame's linear radiance (CV_32FC3, the depth's size).
DirectionalShadowEvidence EstimateShadowsToward(const cv::Mat& depth_m, const cv::Mat& normals, const cv::Mat& mask,
                                                const PinholeIntrinsics& intrinsics, const Eigen::Vector3d& direction,
                                                const RadianceImage& radiance, const CastShadowOptions& options = {});

}  // namespace relume::processing
