// The sky's brightness against elevation, measured in a photograph's own sky pixels (beyond
// Troccoli & Allen, whose IRMs assume nothing about the sky's distribution).
//
// Why: under a sky brighter at the horizon than at the zenith, two surfaces with the same sky
// view v (SkyViewFraction) receive different sky light when one sees the horizon and the other
// only the zenith (the ground between two buildings). The IRM's sun + sky model weighs every
// sky direction alike; with the shape measured here it weighs them as the sky does.
//
// Conventions:
//  - Model per linear RGB channel c: L_c(w) = a_c (1 + g_c z), z = w_z, the sine of the
//    direction's elevation (the mesh frame's z is up: ENU, or a UTM grid with heights).
//    g = 0 is a uniform sky; the world's gradient sky (horizon H, zenith Z) has g = Z / H - 1.
//  - The sky irradiance of a surface whose unblocked sky is Omega is then
//      E_c = pi a_c (v + g_c m),  v = (1/pi) int_Omega cos,  m = (1/pi) int_Omega z cos
//    (SkyViewMoments gives both): open flat ground v = 1, m = 2/3.
//  - Sky pixels: pixels whose camera ray hits no geometry and points above the horizon, that
//    are finite, not masked, and farther than `sun_exclusion_rad` from the sun (the sun's disk
//    and its aureole are no part of the diffuse sky).
//  - The fit covers the elevations the photograph sees and extends linearly in z beyond them
//    (to the zenith, usually): a simple model, exact for the sim's gradient sky; a real clear
//    sky also brightens toward the sun, which it leaves to the sun term.
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <string>

#include "core/pinhole.h"
#include "processing/geometry/ray_caster.h"

namespace relume::irm {

struct SkyShapeOptions {
  int max_rays = 250000;                                    // sky pixels are found on a grid of at most this many
  float sun_exclusion_rad = 10.0f * 3.14159265f / 180;      // circumsolar region left out
  float min_elevation_span_rad = 5.0f * 3.14159265f / 180;  // the sky seen must span this much elevation
  int min_pixels = 100;
  float trim_fraction = 0.1f;      // refit without this share of the largest residuals (clouds, edges)
  float max_abs_gradient = 10.0f;  // beyond: not a sky the model describes (refused, uniform kept)
  bool IsValid(std::string* why) const;
};

struct SkyShape {
  bool measured = false;                               // false: gradient stays 0 (uniform), `reason` says why
  Eigen::Vector3f gradient = Eigen::Vector3f::Zero();  // g per channel
  Eigen::Vector3f horizon = Eigen::Vector3f::Zero();   // a per channel (radiance at the horizon, the image's units)
  int pixels = 0;
  float min_elevation_rad = 0.0f, max_elevation_rad = 0.0f;
  double rms_relative_residual = 0.0;  // of the kept pixels
  std::string reason;
};

// `radiance`: linear CV_32FC3 of the camera's size; `mask`: CV_8UC1, non-zero = not to be
// trusted (saturated or black in every exposure), or empty; `sun_dir`: unit, toward the sun.
SkyShape FitSkyShape(const RayCaster& caster, const cv::Mat& radiance, const PinholeCamera& camera, const cv::Mat& mask,
                     const Eigen::Vector3f& sun_dir, const SkyShapeOptions& options = {});

}  // namespace relume::irm
