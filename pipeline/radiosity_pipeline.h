// The `radiosity` pipeline of `relume process` (radiosity_pipeline.cc, docs/radiosity.md).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/fields.h"
#include "pipeline/pipeline.h"

namespace relume::pipeline {

// One material's albedo estimates against its true albedo: the mean of the estimates, its error
// (mean over the channels of |mean - truth|), the mean |estimate - truth| and the estimates'
// spread (standard deviation, mean of the channels). `patches` or `pixels`: what one estimate is,
// and how many.
struct MaterialAlbedoError {
  std::string material;
  Eigen::Vector3d truth = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  double error_of_mean = 0.0;
  std::optional<std::int64_t> patches, pixels;
  double mean_abs_error = 0.0;
  double spread_sd = 0.0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("material", material);
    v.Field("truth", truth);
    v.Field("mean", mean);
    v.Field("error_of_mean", error_of_mean);
    v.Field("patches", patches);
    v.Field("pixels", pixels);
    v.Field("mean_abs_error", mean_abs_error);
    v.Field("spread_sd", spread_sd);
  }
};

// Albedo estimates (per patch or per pixel) against the truth, per material and over all; the
// maxima over materials with enough estimates.
struct AlbedoErrorFigures {
  std::vector<MaterialAlbedoError> materials;
  double mean_abs_error = 0.0;
  double max_error_of_material_mean = 0.0;
  double max_spread_sd = 0.0;
  std::optional<std::int64_t> patches, pixels;  // estimates compared
  template <typename V>
  void VisitFields(V& v) {
    v.Field("materials", materials);
    v.Field("mean_abs_error", mean_abs_error);
    v.Field("max_error_of_material_mean", max_error_of_material_mean);
    v.Field("max_spread_sd", max_spread_sd);
    v.Field("patches", patches);
    v.Field("pixels", pixels);
  }
};

// Stage radiosity-scale's record (scale.json): bracket 0's absolute scale and how it was found.
// scale=chart fills the reference fit's fields, scale=truth the oracle's (samples, spread); with a
// chart and compare_truth the oracle's scale stands beside the chart's.
struct RadiosityScaleRecord {
  std::string mode;
  double scale = 1.0;
  std::optional<std::int64_t> samples;
  std::optional<double> relative_spread;
  std::optional<double> direct_only_scale;
  std::optional<int> reference_patches;
  std::optional<double> indirect_share;
  std::optional<std::vector<double>> history;
  std::optional<int> solves;
  std::optional<bool> converged;
  std::optional<std::string> reason;
  std::optional<double> seconds;
  std::optional<double> truth_scale;
  std::optional<double> error_against_truth;  // chart scale / truth scale - 1
  template <typename V>
  void VisitFields(V& v) {
    v.Field("mode", mode);
    v.Field("scale", scale);
    v.Field("samples", samples);
    v.Field("relative_spread", relative_spread);
    v.Field("direct_only_scale", direct_only_scale);
    v.Field("reference_patches", reference_patches);
    v.Field("indirect_share", indirect_share);
    v.Field("history", history);
    v.Field("solves", solves);
    v.Field("converged", converged);
    v.Field("reason", reason);
    v.Field("seconds", seconds);
    v.Field("truth_scale", truth_scale);
    v.Field("error_against_truth", error_against_truth);
  }
};

// The planner's estimate of the indirect light (skip or run the radiosity iterations).
struct IndirectShareFigures {
  double estimate = 0.0;  // indirect / direct reflected power, all bounces
  double first_bounce_ratio = 0.0;
  double series_ratio = 0.0;
  double mean_enclosure = 0.0;
  double tolerance = 0.0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("estimate", estimate);
    v.Field("first_bounce_ratio", first_bounce_ratio);
    v.Field("series_ratio", series_ratio);
    v.Field("mean_enclosure", mean_enclosure);
    v.Field("tolerance", tolerance);
  }
};

struct ReflectanceIterationFigures {
  int iteration = 0;
  std::vector<double> image_scale;
  std::optional<AlbedoErrorFigures> truth;  // compare_truth
  template <typename V>
  void VisitFields(V& v) {
    v.Field("iteration", iteration);
    v.Field("image_scale", image_scale);
    v.Field("truth", truth);
  }
};

// Mean and standard deviation of (model / photograph - 1) over patches and channels.
struct RelativeDifferenceFigures {
  double mean_relative_difference = 0.0;
  double sd_relative_difference = 0.0;
  int samples = 0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("mean_relative_difference", mean_relative_difference);
    v.Field("sd_relative_difference", sd_relative_difference);
    v.Field("samples", samples);
  }
};

// The model's own floor: the radiosity solution with the true albedo against bracket 0's
// photograph, per observed patch, and with the direct light at the pixels' own points.
struct ModelGapFigures {
  RelativeDifferenceFigures per_patch;  // its fields at this level
  std::optional<RelativeDifferenceFigures> at_pixels;
  template <typename V>
  void VisitFields(V& v) {
    per_patch.VisitFields(v);
    v.Field("at_pixels", at_pixels);
  }
};

// The converged radiosity solution under bracket 0's lamps.
struct RadiositySolutionFigures {
  std::string summary;
  bool converged = false;
  std::int64_t links = 0;
  double relative_rms_vs_bracket0 = 0.0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("summary", summary);
    v.Field("converged", converged);
    v.Field("links", links);
    v.Field("relative_rms_vs_bracket0", relative_rms_vs_bracket0);
  }
};

// Stage radiosity-reflectance's record (metrics.json): the reflectance iterations and, with
// compare_truth, the albedo against the truth before, after and per pixel.
struct RadiosityReflectanceRecord {
  int iterations = 0;
  bool converged = false;
  std::string reason;
  bool radiosity_skipped = false;
  std::vector<double> image_scale;
  std::vector<int> scale_samples;
  std::vector<double> max_change;
  int clamped = 0;
  double seconds = 0.0;
  std::vector<ReflectanceIterationFigures> per_iteration;
  std::optional<AlbedoErrorFigures> truth_before, truth_after, truth_pixels;
  RadiositySolutionFigures solution;
  std::optional<ModelGapFigures> model_gap_true_albedo_vs_bracket0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("iterations", iterations);
    v.Field("converged", converged);
    v.Field("reason", reason);
    v.Field("radiosity_skipped", radiosity_skipped);
    v.Field("image_scale", image_scale);
    v.Field("scale_samples", scale_samples);
    v.Field("max_change", max_change);
    v.Field("clamped", clamped);
    v.Field("seconds", seconds);
    v.Field("per_iteration", per_iteration);
    v.Field("truth_before", truth_before);
    v.Field("truth_after", truth_after);
    v.Field("truth_pixels", truth_pixels);
    v.Field("solution", solution);
    v.Field("model_gap_true_albedo_vs_bracket0", model_gap_true_albedo_vs_bracket0);
  }
};

// Stage radiosity-relight's record (metrics.json): the new lamp, the solution and, with
// compare_truth, the relit image against the truth (or why it was not compared).
struct RadiosityRelightRecord {
  Eigen::Vector3d light_m = Eigen::Vector3d::Zero();
  double light_intensity_w_sr = 0.0;
  std::string solution;
  std::optional<std::string> truth_not_compared;
  std::optional<double> truth_relative_rms_per_patch;
  std::optional<double> truth_relative_rms_per_pixel;
  std::optional<double> truth_mean_ratio;  // relit / truth, summed over compared patches
  std::optional<int> truth_patches;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("light_m", light_m);
    v.Field("light_intensity_w_sr", light_intensity_w_sr);
    v.Field("solution", solution);
    v.Field("truth_not_compared", truth_not_compared);
    v.Field("truth_relative_rms_per_patch", truth_relative_rms_per_patch);
    v.Field("truth_relative_rms_per_pixel", truth_relative_rms_per_pixel);
    v.Field("truth_mean_ratio", truth_mean_ratio);
    v.Field("truth_patches", truth_patches);
  }
};

// The radiosity pipeline's summary (summary.json "metrics"); what a run did not reach is absent.
struct RadiosityPipelineSummary {
  std::optional<int> patches;
  std::optional<std::int64_t> mesh_triangles;
  std::optional<std::int64_t> patches_seen;  // by any bracket
  std::optional<RadiosityScaleRecord> absolute_scale;
  std::optional<IndirectShareFigures> indirect_share;
  std::optional<RadiosityReflectanceRecord> reflectance;
  std::optional<RadiosityRelightRecord> relight;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("patches", patches);
    v.Field("mesh_triangles", mesh_triangles);
    v.Field("patches_seen", patches_seen);
    v.Field("absolute_scale", absolute_scale);
    v.Field("indirect_share", indirect_share);
    v.Field("reflectance", reflectance);
    v.Field("relight", relight);
  }
};

// Runs the pipeline on `run`'s session and returns what it measured.
RadiosityPipelineSummary RunRadiosityPipeline(PipelineRun& run);

PipelineEntry RadiosityPipelineEntry();

}  // namespace relume::pipeline
