// Relighting by the ratio of irradiances (Ogura & Saito eq. 7), from SH lights (RelightSh) or
// non-negative directional lights (RelightNonNegative, nonneg_light.h):
//   I_dst(x) = I_src(x) * E_dst(n(x)) / E_src(n(x)),
// per channel, with both lights in the camera frame (processing/sh.h). Albedo cancels.
//
// Near-zero denominators: a pixel whose source irradiance in any channel is below
// min_irradiance_fraction times that channel's mean source irradiance over the pixels to
// relight (mask, finite normal and colour) is not divided: it is left out of the valid mask, set to NaN in the relit
// image, and counted in the summary. So are pixels without a finite normal or colour.
// The default 0.1 (0.05 until 2026-12-07): just above 0.05, a pixel whose fitted E_src is a
// fraction of what it receives is multiplied many times over; such pixels took a bounce-lit
// random scene (bounces suite, scene 59) from 20.7 to 46 % relit RMS. Random SH suites (60 scenes, seed 1), median /
// p90 / worst at 0.05 -> 0.1: ideal depth 10.1 / 27.8 / 70.3 -> 9.96 / 25.0 / 70.3 %, Kinect noise 16.0 / 31.4 / 92.8
// -> 15.4 / 29.5 / 55.7 %, smooth lights 3.02 / 9.36 / 26.2 -> 3.02 / 9.31 / 14.8 %, with bounces 3.62 / 12.5 / 46.0
// -> 3.62 / 12.5 / 21.3 %. The cost: fewer pixels relit on lamp-lit scenes (median share of the object 97.9 -> 97.4 %,
// p10 91.8 -> 86.5 %, ideal depth, summed by hand from suite.csv's "relit X of Y px"; unchanged under smooth lights),
// pixels near the lamps' terminators, where order-2 SH is furthest from the clamped cosine.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

#include "core/image.h"
#include "processing/nonneg_light.h"
#include "processing/sh.h"

namespace relume::processing {

struct RelightOptions {
  double min_irradiance_fraction = 0.1;  // see above
  // The ratio E_dst(n) / E_src(n) is filtered before it multiplies the source: a joint bilateral
  // filter over the relit pixels guided by the source image's log luminance, as flash / no-flash
  // photography filters one image guided by another (Petschnigg et al. 2004; Eisemann & Durand
  // 2004). Illumination changes smoothly within a surface, and where it does not (a crease, a
  // silhouette, a shadow edge) the source's shading changes too; so the filter averages the
  // error of per-pixel normals (noisy depth, blended creases, silhouettes) without crossing
  // them. Its cost is a bias on curved surfaces, where the ratio also changes along the
  // source's isophotes: with exact normals and exact lights the analytic SH scene relights
  // 0.20 % off (relight_test.cc; exact without it), with its fitted light and the true normals
  // 0.48 % against 0.19 % (sh_accuracy_test.cc). Random SH suites (60 scenes, seed 1,
  // 2026-12-05, guard 0.05), median / p90 without -> with: Kinect noise 20.5 / 43.9 -> 16.0 / 31.4 %, ideal
  // depth 12.1 / 33.7 -> 10.1 / 27.8 %, smooth lights 4.11 / 10.0 -> 3.02 / 9.36 %. Wider
  // (radius 4, sigma 2.67 px) gains more on the suites (Kinect 14.6 %) and costs more bias
  // (0.76 % with the fitted light). 0: off, each pixel by its own ratio.
  int ratio_radius_px = 3;
  double ratio_spatial_sigma_px = 1.5;
  double ratio_range_sigma = 0.015;  // of the natural log of the source's luminance (1.5 %)
  // Normals from depth that measured noisy (the SH geometry step filtered it:
  // ShGeometry::depth_filtered, ShFrameEstimate::depth_filtered; a Kinect-like sensor) carry
  // more error for the filter to average than the bias a wider one adds: with
  // normals_from_noisy_depth set, the filter is noisy_ratio_* instead of ratio_*. Random SH
  // suites (60 scenes, seed 1, 320x240, 2026-12-07), Kinect noise, median / p90 / worst with the
  // filter above -> (4, 2.67, 0.015) -> (5, 3.0, 0.03) -> (6, 4.0, 0.03) -> (8, 5.33, 0.03):
  // 15.4 / 29.5 / 55.7 -> 13.9 / 27.7 / 53.6 -> 13.1 / 26.7 / 52.9 -> 12.7 / 25.9 / 52.1 ->
  // 13.1 / 24.9 / 51.6 % (floor, true normals each by its own ratio: 8.84 / 25.9 / 60.6 %).
  // The radius is in pixels: at a higher resolution the same surface spans more of them.
  bool normals_from_noisy_depth = false;
  int noisy_ratio_radius_px = 6;
  double noisy_ratio_spatial_sigma_px = 4.0;
  double noisy_ratio_range_sigma = 0.03;
  // The shading check, before the ratio filter. The ratio assumes that the pixel's shading is
  // E_src at its normal: I = a E_src(n). Where depth gives a normal its shading contradicts (a
  // box face seen edge-on, one pixel wide, given the normal of the face beside it; a wrong
  // normal at a crease), the ratio divides a bright pixel by a small E_src and multiplies it
  // many times over: on the random SH suites single rows of such pixels were relit 10-40x too
  // bright and carried most of a scene's squared error. The check compares each pixel's implied
  // albedo a = I / E_src(n) (luminance: sums over channels) with the median of its neighbours'
  // within albedo_check_radius_px whose chromaticity (r, g) / (r + g + b) is within
  // albedo_check_chromaticity_tolerance (L1) of its own (the same material; at least 8 of them,
  // itself counted). More than max_albedo_deviation times above it, the pixel is relit as
  // a_ref E_dst(n), a_ref being those neighbours' per-channel median albedo, and counted in
  // RelightSummary::albedo_replaced_pixel_count.
  //  - One-sided: a pixel darker than its normal implies is left to the ratio, which keeps
  //    whatever darkens it (a cast shadow, occlusion) and cannot multiply it by much. Checked
  //    both ways, the check lit the edges of the lamp shadows on the floor session (99 pixels;
  //    relit 8.98 -> 9.19 %); one-sided it replaces none there.
  //  - Without the chromaticity test the median mixes objects, and the true normals' floor on
  //    the smooth-light suite rose from 0.05 to 0.63 %.
  // Random SH suites (60 scenes, seed 1, 320x240, 2026-12-07), non-negative light, median / p90
  // / worst, off -> on: see docs/processing-sh.md. 0: off.
  double max_albedo_deviation = 2.0;
  int albedo_check_radius_px = 3;
  double albedo_check_chromaticity_tolerance = 0.05;
  bool IsValid(std::string* why) const;
};

struct RelightSummary {
  int requested_pixel_count = 0;  // mask pixels
  int relit_pixel_count = 0;
  int guarded_pixel_count = 0;  // source irradiance too small to divide by
  int invalid_input_count = 0;  // no normal or non-finite colour
  // relit from their neighbours' albedo: shading contradicts the normal (max_albedo_deviation)
  int albedo_replaced_pixel_count = 0;
  std::string message;
};

struct RelightResult {
  RadianceImage relit;  // RGB; NaN outside `valid`
  cv::Mat valid;        // CV_8UC1, 255 where relit
  RelightSummary summary;
};

// src: RGB radiance; normal_in_camera: CV_32FC3; mask: CV_8UC1 (non-zero = relight this
// pixel; may be empty for all pixels). Throws InvalidArgumentError on mismatched inputs.
RelightResult RelightSh(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                        const ShRgb& src_light, const ShRgb& dst_light, const RelightOptions& options = {});

// The same relighting with non-negative directional lights (nonneg_light.h) for E_src and E_dst,
// options and summary as above. Throws InvalidArgumentError on mismatched inputs or a light with
// a negative or non-finite irradiance.
RelightResult RelightNonNegative(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                                 const NonNegativeLight& src_light, const NonNegativeLight& dst_light,
                                 const RelightOptions& options = {});

// Places `foreground` over `background` where mask is non-zero and the foreground is finite;
// elsewhere the background shows. Sizes must match.
RadianceImage Composite(const RadianceImage& foreground, const cv::Mat& mask, const RadianceImage& background);

}  // namespace relume::processing
