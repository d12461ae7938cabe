// `relume process SESSION --pipeline irm --source FRAME --target FRAME [--mesh FILE]`:
// Troccoli & Allen's irradiance ratio maps (processing/irm/) on a recorded session. The source
// bracket is relit to the light of the target bracket (docs/irm.md).
//
// Stages (each cached by a StageKey, so an unchanged re-run reuses everything and a changed
// knob recomputes only what depends on it):
//   irm-mesh    the scene mesh, split (mesh_spacing_m), as mesh.bin
//   irm-view    per photograph: vertex visibility and sun fractions (mesh, camera, sun, sun_samples)
//   irm-sky     per photograph: the sky's brightness against elevation (view + its radiance)
//   irm-build   the IRMs from the vertices seen in both (+ radiance of both, bins, thresholds)
//   irm-relight every source pixel (+ exact_shadow_edges); relit EXR, preview, status, seam
//   irm-truth   simulated sessions: the relit image against the world's truth, per region
// The mesh comes from the session's recorded world (<session>/rig/) or from --mesh (OBJ/PLY, in
// ENU, or UTM with --set mesh_frame=utm); cameras from the rig's device specs; sun directions
// from the frames' recorded azimuth and elevation.
//
// Knobs (--set; `relume process --list --pipeline irm` lists them with their defaults): IrmKnobs
// in irm_pipeline.cc, each declared once with the stages it changes (knobs.h).
#pragma once

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "pipeline/pipeline.h"
#include "processing/geometry/ray_caster.h"
#include "processing/irm/irm.h"
#include "processing/irm/relight.h"
#include "processing/irm/sky_shape.h"
#include "processing/metrics.h"

// The field lists of processing's result types that the irm pipeline's records and summary hold
// (pipeline/fields.h; free functions found by argument-dependent lookup).
namespace relume::irm {

template <typename V>
void VisitFields(V& v, RelightSummary& s) {
  v.Field("vertices", s.vertices);
  v.Field("visible_in_both", s.visible_in_both);
  v.Field("consistent_samples", s.consistent_samples);
  v.Field("irm_summary", s.irm_summary);
  v.Field("pixels_relit", s.pixels_relit);
  v.Field("pixels_without_geometry", s.pixels_without_geometry);
  v.Field("pixels_without_ratio", s.pixels_without_ratio);
  v.Field("pixels_masked", s.pixels_masked);
  v.Field("pixels_with_own_sun_rays", s.pixels_with_own_sun_rays);
  v.Field("pixels_with_own_sky_rays", s.pixels_with_own_sky_rays);
  v.Field("pixels_with_own_indirect_rays", s.pixels_with_own_indirect_rays);
  v.Field("overlap_vertex_rms_before", s.overlap_rms_before);
  v.Field("overlap_vertex_rms_after", s.overlap_rms_after);
  v.Field("indirect_rays", s.indirect_rays);
  v.Field("indirect_hit_share", s.indirect_hit_share);
  v.Field("indirect_filled_source", s.indirect_filled_source);
  v.Field("indirect_filled_target", s.indirect_filled_target);
  v.Field("indirect_s", s.indirect_s);
  v.Field("preprocess_s", s.preprocess_s);
  v.Field("build_s", s.build_s);
  v.Field("relight_s", s.relight_s);
}

// Floats through JSON doubles: exact both ways.
template <typename V>
void VisitFields(V& v, SkyShape& s) {
  v.Field("measured", s.measured);
  v.Field("gradient", s.gradient);
  v.Field("horizon", s.horizon);
  v.Field("pixels", s.pixels);
  v.Field("min_elevation_rad", s.min_elevation_rad);
  v.Field("max_elevation_rad", s.max_elevation_rad);
  v.Field("rms_relative_residual", s.rms_relative_residual);
  v.Field("reason", s.reason);
}

// An IRM set as the irm-build stage stores it (irms.json; the per-vertex light goes to a binary
// file of its own). The maps' order is MapKind's.
template <typename V>
void VisitFields(V& v, RatioMap& m) {
  v.Field("bins", m.bins);
  v.Field("count", m.count);
  v.Field("source", m.source);
  v.Field("ratio", m.ratio);
  v.Field("mean_normal", m.mean_normal);
  v.Field("mean_sky_view", m.mean_sky_view);
  v.Field("mean_sky_moment", m.mean_sky_moment);
  v.Field("model_ratio", m.model_ratio);
}

template <typename V>
void VisitFields(V& v, SunSkyModel& m) {
  v.Field("valid", m.valid);
  v.Field("sun_source", m.sun_source);
  v.Field("sun_target", m.sun_target);
  v.Field("sky_target", m.sky_target);
  v.Field("sun_dir_source", m.sun_dir_source);
  v.Field("sun_dir_target", m.sun_dir_target);
  v.Field("sky_gradient_source", m.sky_gradient_source);
  v.Field("sky_gradient_target", m.sky_gradient_target);
  v.Field("indirect_scale", m.indirect_scale);
  v.Field("indirect_reason", m.indirect_reason);
  v.Field("rms_relative_residual", m.rms_relative_residual);
  v.Field("rms_ratio_error", m.rms_ratio_error);
  v.Field("condition_number", m.condition_number);
  v.Field("reason", m.reason);
}

template <typename V>
void VisitFields(V& v, IndirectShare& s) {
  v.Field("source_lit", s.source_lit);
  v.Field("source_shadow", s.source_shadow);
  v.Field("target_lit", s.target_lit);
  v.Field("target_shadow", s.target_shadow);
  v.Field("source_lit_samples", s.source_lit_samples);
  v.Field("source_shadow_samples", s.source_shadow_samples);
  v.Field("target_lit_samples", s.target_lit_samples);
  v.Field("target_shadow_samples", s.target_shadow_samples);
}

// One map of an IrmSet with its kind's name ("lit_to_lit", ...), so irms.json says which is which.
struct NamedRatioMap {
  std::string kind;
  RatioMap* map = nullptr;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("kind", kind);
    irm::VisitFields(v, *map);
  }
};

template <typename V>
void VisitFields(V& v, IrmSet& s) {
  std::array<NamedRatioMap, 4> maps;
  for (std::size_t k = 0; k < maps.size(); ++k) maps[k] = {ToString(static_cast<MapKind>(k)), &s.maps[k]};
  v.Field("maps", maps);  // read in place: each entry fills its own map
  v.Field("model", s.model);
  v.Field("single_map", s.single_map);
  v.Field("samples_used", s.samples_used);
  v.Field("samples_in_penumbra", s.samples_in_penumbra);
  v.Field("samples_too_dark", s.samples_too_dark);
  v.Field("summary", s.summary);
  v.Field("lit_threshold", s.lit_threshold);
  v.Field("shadow_threshold", s.shadow_threshold);
  v.Field("model_correction", s.model_correction);
  v.Field("indirect_share", s.indirect_share);
}

}  // namespace relume::irm

namespace relume::metrics {

template <typename V>
void VisitFields(V& v, SunRegionErrors& e) {
  v.Field("scale", e.scale);
  v.Field("relative_rms_all", e.all);
  v.Field("relative_rms_lit", e.lit);
  v.Field("relative_rms_shadow", e.shadow);
  v.Field("relative_rms_penumbra", e.penumbra);
  v.Field("lit_pixels", e.lit_pixels);
  v.Field("shadow_pixels", e.shadow_pixels);
  v.Field("penumbra_pixels", e.penumbra_pixels);
}

}  // namespace relume::metrics

namespace relume::pipeline {

// The seam between the relit source and the target photograph (stage irm-relight): relative
// RMS of relit (after) and source (before) against the target where both see a surface, and on
// the ring of pixels along the edge of what the target sees.
struct IrmSeamFigures {
  std::int64_t overlap_pixels = 0;
  double overlap_relative_rms_before = 0.0;
  double overlap_relative_rms_after = 0.0;
  std::int64_t seam_pixels = 0;
  double seam_relative_rms_before = 0.0;
  double seam_relative_rms_after = 0.0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("overlap_pixels", overlap_pixels);
    v.Field("overlap_relative_rms_before", overlap_relative_rms_before);
    v.Field("overlap_relative_rms_after", overlap_relative_rms_after);
    v.Field("seam_pixels", seam_pixels);
    v.Field("seam_relative_rms_before", seam_relative_rms_before);
    v.Field("seam_relative_rms_after", seam_relative_rms_after);
  }
};

// Stage irm-relight's record (relight.json): the library's summary of the relighting, the seam,
// and the white the previews share.
struct IrmRelightRecord {
  irm::RelightSummary summary;
  IrmSeamFigures seam;
  double preview_white = 1.0;
  template <typename V>
  void VisitFields(V& v) {
    irm::VisitFields(v, summary);  // its fields at this level
    v.Field("seam", seam);
    v.Field("preview_white", preview_white);
  }
};

template <typename T>
struct SourceAndTargetFigures {
  T source{};
  T target{};
  template <typename V>
  void VisitFields(V& v) {
    v.Field("source", source);
    v.Field("target", target);
  }
};

// Interreflection in the relighting model (irm.h, indirect.h): whether the gathered light was
// used, the model's scale for it and the share of each region's light it makes.
struct IrmIndirectFigures {
  bool used = false;
  Eigen::Vector3f scale = Eigen::Vector3f::Zero();
  std::string reason;
  double share_source_lit = 0.0, share_source_shadow = 0.0;
  double share_target_lit = 0.0, share_target_shadow = 0.0;
  // The fitted scale against what the source's sky radiance predicts, 1 / (pi a_s): near 1 when
  // the gathered light and the sky's units agree. Absent when the sky was not measured.
  std::optional<Eigen::Vector3f> scale_over_sky_prediction;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("used", used);
    v.Field("scale", scale);
    v.Field("reason", reason);
    v.Field("share_source_lit", share_source_lit);
    v.Field("share_source_shadow", share_source_shadow);
    v.Field("share_target_lit", share_target_lit);
    v.Field("share_target_shadow", share_target_shadow);
    v.Field("scale_over_sky_prediction", scale_over_sky_prediction);
  }
};

// The mesh the IRMs sampled: where it came from and its size after splitting.
struct IrmMeshFigures {
  std::string origin;
  std::int64_t vertices = 0, triangles = 0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("origin", origin);
    v.Field("vertices", vertices);
    v.Field("triangles", triangles);
  }
};

// What the relighting did: its record, the mesh, the views' cast-shadow counts and sky shapes.
struct IrmResultFigures {
  IrmRelightRecord relight;  // its fields at this level
  IrmMeshFigures mesh;
  SourceAndTargetFigures<int> visible_in_cast_shadow;  // visible vertices in cast shadow
  bool single_map = false;                             // one IRM (no sample in cast shadow in both)
  IrmIndirectFigures indirect;
  SourceAndTargetFigures<irm::SkyShape> sky_shape;
  template <typename V>
  void VisitFields(V& v) {
    relight.VisitFields(v);
    v.Field("mesh", mesh);
    v.Field("visible_in_cast_shadow", visible_in_cast_shadow);
    v.Field("single_map", single_map);
    v.Field("indirect", indirect);
    v.Field("sky_shape", sky_shape);
  }
};

// Stage irm-truth's record (truth.json): the relit source, and the source not relit, against the
// truth per sun region (one fitted scale per image), with what was left out of the comparison.
struct IrmTruthRecord {
  std::optional<std::string> truth;  // "external: DIR" for a truth made outside relume
  // The simulated world's truth: relit pixels where mesh and truth disagree on the surface, or
  // on the shadows it casts (left out, GeometryAgreement, ShadowAgreement).
  std::optional<std::int64_t> geometry_mismatch_pixels, shadow_geometry_mismatch_pixels;
  // An external truth: relit pixels off its surfaces (left out).
  std::optional<std::int64_t> relit_pixels_off_the_truths_surfaces;
  metrics::SunRegionErrors relit, no_relighting;
  // An external truth with source.exr: the linearised source photograph against it, the floor
  // the relit image inherits.
  std::optional<metrics::SunRegionErrors> source_photograph;
  std::string comparison;
  std::optional<double> target_sun_direction_error_deg;  // recorded sun vs the world's
  template <typename V>
  void VisitFields(V& v) {
    v.Field("truth", truth);
    v.Field("geometry_mismatch_pixels", geometry_mismatch_pixels);
    v.Field("shadow_geometry_mismatch_pixels", shadow_geometry_mismatch_pixels);
    v.Field("relit_pixels_off_the_truths_surfaces", relit_pixels_off_the_truths_surfaces);
    v.Field("relit", relit);
    v.Field("no_relighting", no_relighting);
    v.Field("source_photograph", source_photograph);
    v.Field("comparison", comparison);
    v.Field("target_sun_direction_error_deg", target_sun_direction_error_deg);
  }
};

// The irm pipeline's summary (summary.json "metrics"). Both absent when it only planned.
struct IrmSummary {
  std::optional<IrmResultFigures> irm;
  std::optional<IrmTruthRecord> truth;  // compared with a truth (simulated, or --set truth_dir)
  template <typename V>
  void VisitFields(V& v) {
    v.Field("irm", irm);
    v.Field("truth", truth);
  }
};

// Runs the pipeline on `run`'s session and returns what it measured.
IrmSummary RunIrmPipeline(PipelineRun& run);

// The pipeline as `relume process` lists it: name, description, run function and knobs.
PipelineEntry IrmPipelineEntry();

// An IRM set as JSON and back (NaN ratios as null), for the irm-build stage's output (its field
// lists above). Reading throws IoError naming `source` and the field for a field of the wrong
// type, and InvalidArgumentError when a map's arrays do not hold bins x bins values.
nlohmann::json IrmSetToJson(const irm::IrmSet& set);
irm::IrmSet IrmSetFromJson(const nlohmann::json& json, const std::string& source = "IRM file");

// Pixels where the mesh and the truth see the same surface: the distance along the pixel's ray
// to the first hit of `caster` within 1% of the truth's (depth_m is along the optical axis).
// Silhouette pixels of a tessellated surface and mesh/truth disagreements are not the IRM's
// error and would dominate a relative RMS; they are left out and counted. CV_8UC1, 255 = agree.
cv::Mat GeometryAgreement(const RayCaster& caster, const PinholeCamera& camera, const cv::Mat& truth_depth_m);

// Of those pixels, the ones where the mesh also casts the shadows the world casts: for each
// photograph, the mesh's own sun fraction at the pixel's surface point (SunVisibleFraction,
// `sun_samples` rays over the disk) within `tolerance` of the truth's sun visibility. A
// tessellated sphere's polygonal shadow, or an occluder the mesh lacks, moves shadow edges by
// a few pixels; relit there with the mesh's (correct for the mesh) fraction, one such pixel at
// 0.2 instead of 0 costs a 4x ratio and would dominate the shadow figure. Left out and counted.
struct SunCheck {
  Eigen::Vector3f sun_dir;              // unit, toward the sun, mesh frame
  const cv::Mat* truth_sun_visibility;  // CV_32FC1, the truth's visible fraction per pixel
};
cv::Mat ShadowAgreement(const RayCaster& caster, const PinholeCamera& camera, const cv::Mat& agree,
                        const std::vector<SunCheck>& suns, int sun_samples = 64, float tolerance = 0.1f);

}  // namespace relume::pipeline
