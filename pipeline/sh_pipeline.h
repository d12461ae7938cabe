// `relume process SESSION --pipeline sh`: SH lighting estimation and relighting of a recorded
// RGB-D stream (Ogura & Saito 2015; Ogura et al.; the library in processing/, see
// docs/processing-sh.md).
//
// Per RGB-D pair (depth + colour of one device, paired by time), three cached stages:
//   radiance-<id>  the colour frame as linear radiance
//   geometry-<id>  bilateral + temporal depth filter, normals (or the previous frame's normals
//                  when the depth did not change beyond tolerance), object mask
//   fit-<id>       SH light (known albedo from the rig's world, or unknown albedo by k-means)
// and, for every source frame, relight-<id>: I_dst = I_src E_dst(n) / E_src(n), composited over
// the source. Frames and lights are in the colour camera's frame (x right, y down, z forward).
//
// SH light JSON (written per frame, read by --target-light FILE.json):
//   {"convention": "...", "frame": "camera", "order": 2,
//    "coefficients": [[R, G, B] x 9]}   rows k = l (l + 1) + m, processing/sh.h's basis.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"
#include "processing/sh.h"

namespace relume::pipeline {

nlohmann::json ShLightToJson(const processing::ShRgb& light, int order);
// Throws InvalidArgumentError naming `what` when the JSON is not an SH light.
processing::ShRgb ShLightFromJson(const nlohmann::json& json, const std::string& what);

// The library's fit summary (processing/sh_fit.h) and how the albedo was found: light.json "fit"
// (stage fit-<id>).
struct ShFitFigures {
  bool usable = false;
  int order_used = -1;
  bool order_reduced = false;
  int observations = 0;
  double condition_number = 0.0;
  double condition_number_order2 = 0.0;
  double normal_solid_angle_sr = 0.0;
  double relative_rms_residual = 0.0;
  std::optional<double> albedo_light_condition_number;  // unknown albedo only
  int iterations = 0;
  bool converged = false;
  std::string message;
  std::string albedo;  // truth (an oracle) or unknown (k-means segments)
  std::optional<int> segments;
  std::optional<std::vector<Eigen::Vector3d>> segment_albedo;
  // Unknown albedo: the segment whose albedo fixed the scale, and what another frame needs to be
  // labelled with these segments (processing::LabelByCentres): their k-means centres, spreads and
  // the frame's mean colour. The labels are the stage's segments.exr.
  std::optional<int> reference_segment;
  std::optional<std::vector<std::vector<double>>> segment_centres;
  std::optional<std::vector<double>> segment_spread;
  std::optional<Eigen::Vector3d> frame_mean_color;
  // shared_albedo: the colour frame whose segments and albedos this fit used as known, and how
  // many of the fit's pixels kept that frame's label (same surface) or took the nearest
  // chromaticity's; pixels of a material that frame did not show are left out.
  std::optional<std::int64_t> albedo_from_frame;
  std::optional<std::int64_t> same_surface_pixels, chromaticity_labelled_pixels, unlabelled_pixels;
  // Pixels with a normal and depth, and those of them the fit could not sample because the
  // colour frame clipped there (lower bounds).
  std::optional<std::int64_t> pixels_with_normal, clipped_pixels;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("usable", usable);
    v.Field("order_used", order_used);
    v.Field("order_reduced", order_reduced);
    v.Field("observations", observations);
    v.Field("condition_number", condition_number);
    v.Field("condition_number_order2", condition_number_order2);
    v.Field("normal_solid_angle_sr", normal_solid_angle_sr);
    v.Field("relative_rms_residual", relative_rms_residual);
    v.Field("albedo_light_condition_number", albedo_light_condition_number);
    v.Field("iterations", iterations);
    v.Field("converged", converged);
    v.Field("message", message);
    v.Field("albedo", albedo);
    v.Field("segments", segments);
    v.Field("segment_albedo", segment_albedo);
    v.Field("reference_segment", reference_segment);
    v.Field("segment_centres", segment_centres);
    v.Field("segment_spread", segment_spread);
    v.Field("frame_mean_color", frame_mean_color);
    v.Field("albedo_from_frame", albedo_from_frame);
    v.Field("same_surface_pixels", same_surface_pixels);
    v.Field("chromaticity_labelled_pixels", chromaticity_labelled_pixels);
    v.Field("unlabelled_pixels", unlabelled_pixels);
    v.Field("pixels_with_normal", pixels_with_normal);
    v.Field("clipped_pixels", clipped_pixels);
  }
};

// Stage relight-<id>'s record (relight.json): pixels asked for, relit, not divided (irradiance
// too low) and without valid input.
struct ShRelightFigures {
  std::int64_t requested = 0, relit = 0, guarded = 0, invalid_input = 0;
  std::int64_t clipped = 0;  // pixels with a normal left out: clipped in the colour frame (not requested)
  // relit from their neighbours' albedo: shading contradicts the normal (relight_albedo_deviation)
  std::int64_t albedo_replaced = 0;
  std::string message;
  std::string light = "sh";  // the light divided by: "sh" or "nonnegative" (knob light_model)
  template <typename V>
  void VisitFields(V& v) {
    v.Field("requested", requested);
    v.Field("relit", relit);
    v.Field("guarded", guarded);
    v.Field("invalid_input", invalid_input);
    v.Field("clipped", clipped);
    v.Field("albedo_replaced", albedo_replaced);
    v.Field("message", message);
    v.Field("light", light);
  }
};

// Stage shadows-<id>'s record (shadows.json): the cast shadows the fitted light throws within the
// frame's depth (processing/cast_shadow.h).
struct ShCastShadowFigures {
  std::int64_t color_frame = 0;
  double shadowed_fraction = 0.0;
  double directional_share = 0.0;
  double removed_share_rms = 0.0;  // the irradiance share the SH model misses, RMS over the image
  // Toward the sun the session recorded for the frame (when it has a site and the camera a
  // pose, with the sun up; processing::EstimateShadowsToward): the share of the pixels facing it
  // the depth shadows, and how much brighter the lit ones are (NaN: too few on either side).
  std::optional<double> sun_elevation_deg, sun_shadowed_fraction, sun_shadow_contrast;
  std::optional<int> sun_facing_pixels;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("color_frame", color_frame);
    v.Field("shadowed_fraction", shadowed_fraction);
    v.Field("directional_share", directional_share);
    v.Field("removed_share_rms", removed_share_rms);
    v.Field("sun_elevation_deg", sun_elevation_deg);
    v.Field("sun_shadowed_fraction", sun_shadowed_fraction);
    v.Field("sun_shadow_contrast", sun_shadow_contrast);
    v.Field("sun_facing_pixels", sun_facing_pixels);
  }
};

struct ShCastShadowsSummary {
  double removed_share_median = 0.0;  // over frames
  // Medians over the frames assessed toward the recorded sun (absent: none was).
  std::optional<double> sun_shadowed_fraction_median, sun_shadow_contrast_median;
  std::vector<ShCastShadowFigures> frames;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("removed_share_median", removed_share_median);
    v.Field("sun_shadowed_fraction_median", sun_shadowed_fraction_median);
    v.Field("sun_shadow_contrast_median", sun_shadow_contrast_median);
    v.Field("frames", frames);
  }
};

// A frame against the truth (stage truth-<id>'s truth.json for the simulated world; computed for
// an external truth): the fitted irradiance at the true normals, and the relit frame against the
// source geometry under the destination light (signal-relative RMS), or why it was not compared.
struct ShTruthFigures {
  std::optional<std::string> truth;  // "external: DIR"
  std::optional<double> irradiance_relative_rms;
  std::optional<int> irradiance_pixels;
  std::optional<bool> irradiance_scale_removed;  // unknown albedo: a scale per channel taken out first
  std::optional<std::string> truth_under_destination;
  std::optional<double> relit_relative_rms, baseline_relative_rms;
  std::optional<double> relit_rms_8bit, baseline_rms_8bit;  // in 8-bit levels of the preview
  std::optional<std::int64_t> compared_pixels;
  std::optional<double> floor_relative_rms;  // external truth: the destination photograph itself
  std::optional<double> scale_to_truth;      // external truth: the fitted scale to its units
  template <typename V>
  void VisitFields(V& v) {
    v.Field("truth", truth);
    v.Field("irradiance_relative_rms", irradiance_relative_rms);
    v.Field("irradiance_pixels", irradiance_pixels);
    v.Field("irradiance_scale_removed", irradiance_scale_removed);
    v.Field("truth_under_destination", truth_under_destination);
    v.Field("relit_relative_rms", relit_relative_rms);
    v.Field("baseline_relative_rms", baseline_relative_rms);
    v.Field("relit_rms_8bit", relit_rms_8bit);
    v.Field("baseline_rms_8bit", baseline_rms_8bit);
    v.Field("compared_pixels", compared_pixels);
    v.Field("floor_relative_rms", floor_relative_rms);
    v.Field("scale_to_truth", scale_to_truth);
  }
};

// One RGB-D pair: its fit, where its normals came from, its relighting (a source frame other than
// the destination's own) and its errors against a truth.
struct ShFrameFigures {
  std::int64_t color_frame = 0, depth_frame = 0;
  ShFitFigures fit;
  std::int64_t normals_from_frame = 0;
  std::optional<ShRelightFigures> relight;
  // The relit frame against the destination frame's photograph where both show the same
  // surface (signal-relative RMS; destination light from a frame only): no truth needed.
  // The error is absent when under a tenth of the relit pixels are shared.
  std::optional<double> destination_photo_relative_rms;
  std::optional<std::int64_t> destination_photo_pixels;
  ShTruthFigures truth;  // its fields at this level
  template <typename V>
  void VisitFields(V& v) {
    v.Field("color_frame", color_frame);
    v.Field("depth_frame", depth_frame);
    v.Field("fit", fit);
    v.Field("normals_from_frame", normals_from_frame);
    v.Field("relight", relight);
    v.Field("destination_photo_relative_rms", destination_photo_relative_rms);
    v.Field("destination_photo_pixels", destination_photo_pixels);
    truth.VisitFields(v);
  }
};

// Why SH does not fit a scene (ShPipelineSummary::misfit_reasons).
inline constexpr const char* kResidualReason = "fit residual";
inline constexpr const char* kFittedShadowsReason = "cast shadows of the fitted light";
inline constexpr const char* kSunShadowsReason = "cast shadows of the recorded sun";
inline constexpr const char* kDestinationPhotoReason = "relit frames differ from the destination photograph";

// The sh pipeline's summary (summary.json "metrics"); absent: the run did not reach it (planned
// only) or had nothing to compare.
struct ShPipelineSummary {
  std::optional<std::vector<ShFrameFigures>> frames;
  std::optional<std::string> destination;  // the destination light, in words
  std::optional<std::string> albedo;       // truth or unknown
  std::optional<std::int64_t> guarded_pixels, relit_pixels;
  // Means over frames against the truth.
  std::optional<double> irradiance_relative_rms_mean;
  std::optional<double> relit_relative_rms_mean, baseline_relative_rms_mean;
  std::optional<double> relit_rms_8bit_mean, baseline_rms_8bit_mean;
  std::optional<double> floor_relative_rms_mean;  // external truth
  std::optional<int> compared_frames;
  // Median over the relit frames of their error against the destination frame's photograph
  // (ShFrameFigures::destination_photo_relative_rms), and how many frames had one.
  std::optional<double> destination_photo_relative_rms_median;
  std::optional<int> destination_photo_frames;
  // Frames whose colour clipped on at least 5 % of their pixels with a normal (each warned).
  std::optional<int> clipped_frames;
  // Whether SH describes the scene's light (fit residuals, cast shadows; CheckShFitsTheScene),
  // and when not, which checks said so (kResidualReason, kFittedShadowsReason, kSunShadowsReason,
  // kDestinationPhotoReason).
  std::optional<bool> sh_fits_scene;
  std::optional<std::vector<std::string>> misfit_reasons;
  std::optional<double> fit_residual_median;
  std::optional<ShCastShadowsSummary> cast_shadows;
  std::optional<std::string> truth;  // "external: DIR"
  template <typename V>
  void VisitFields(V& v) {
    v.Field("frames", frames);
    v.Field("destination", destination);
    v.Field("albedo", albedo);
    v.Field("guarded_pixels", guarded_pixels);
    v.Field("relit_pixels", relit_pixels);
    v.Field("irradiance_relative_rms_mean", irradiance_relative_rms_mean);
    v.Field("relit_relative_rms_mean", relit_relative_rms_mean);
    v.Field("baseline_relative_rms_mean", baseline_relative_rms_mean);
    v.Field("relit_rms_8bit_mean", relit_rms_8bit_mean);
    v.Field("baseline_rms_8bit_mean", baseline_rms_8bit_mean);
    v.Field("floor_relative_rms_mean", floor_relative_rms_mean);
    v.Field("compared_frames", compared_frames);
    v.Field("destination_photo_relative_rms_median", destination_photo_relative_rms_median);
    v.Field("destination_photo_frames", destination_photo_frames);
    v.Field("clipped_frames", clipped_frames);
    v.Field("sh_fits_scene", sh_fits_scene);
    v.Field("misfit_reasons", misfit_reasons);
    v.Field("fit_residual_median", fit_residual_median);
    v.Field("cast_shadows", cast_shadows);
    v.Field("truth", truth);
  }
};

// Runs the pipeline on `run`'s session and returns what it measured.
ShPipelineSummary RunShPipeline(PipelineRun& run);

// The pipeline as `relume process` lists it: name, description, run function and knobs.
PipelineEntry ShPipelineEntry();

}  // namespace relume::pipeline
