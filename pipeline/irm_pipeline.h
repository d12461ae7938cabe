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
#include "processing/metrics.h"

namespace relume::pipeline {

// The pipeline as `relume process` lists it: name, description, run function and knobs.
PipelineEntry IrmPipelineEntry();

// An IRM set as JSON and back (NaN ratios as null), for the irm-build stage's output.
nlohmann::json IrmSetToJson(const irm::IrmSet& set);
irm::IrmSet IrmSetFromJson(const nlohmann::json& json);

// The errors of a relit image against the truth per sun region (processing/metrics.h:
// per-sample relative RMS after the fitted scale, radiance from a session being relative), as
// summary.json writes them.
nlohmann::json SunRegionErrorsJson(const metrics::SunRegionErrors& errors);

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
