// Non-negative directional lighting: the light as a non-negative sum of distant directional
// sources on a fixed set of directions, fitted to the same observations as the SH fit
// (sh_fit.h: I = albedo * E(n) / pi, camera frame):
//   E(n) = sum_j w_j max(0, n . d_j),  w_j >= 0 per channel,
// w_j being the irradiance source j gives a plane facing it. Lawson & Hanson's active-set
// non-negative least squares (Solving Least Squares Problems, 1974, ch. 23) per channel, on
// normal equations the three channels share: each row in irradiance units (pi I / albedo),
// weighted by the observation's mean albedo / pi.
//
// Why beside the SH fit: order-2 SH band-limits the irradiance, and a lamp's or the sun's
// clamped cosine is not band-limited: its terminator is a kink no 9 coefficients follow. Relit
// by the ratio of two such fits, pixels near the terminators carry errors of tens of per cent
// (random SH suite, lamps, ideal depth, order-2 floor: median 9.8 %, docs/benchmarks.md). A
// light is never negative, and that constraint is what lets a sum of clamped cosines follow a
// terminator from the normals one view shows, where a free fit of as many terms would be
// ill-conditioned. The directions are the fixed grid below; a source between grid directions is
// approximated by its neighbours (the grid is 512 directions, about 9 deg apart). Random SH
// suites (60 scenes, seed 1, 320x240, 2026-12-07), relit median / p90, known albedo: lamps
// 2.90 / 6.50 % (order-2 SH 9.96 / 25.0 %; true normals 0.93 / 2.78 against 9.77 / 26.5 %),
// smooth lights 1.90 / 3.77 % (3.02 / 9.31 %), Kinect-like depth 9.80 / 19.3 % (12.7 / 25.9 %).
//
// The fitted light is also given as SH to order 2 (`ToSh`: each source projects exactly as
// L_k = w_j Y_k(d_j)), for what takes SH (files, displays).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "processing/sh.h"
#include "processing/sh_fit.h"

namespace relume::processing {

struct NonNegativeLightOptions {
  int direction_count = 512;  // on a Fibonacci sphere (all of it: a source behind the object still lights its sides)
  int min_observations = 50;  // fewer: not usable
  // Added to the normal equations' diagonal, relative to their mean diagonal: keeps the active
  // set's solves stable when two directions light the observed normals alike.
  double ridge = 1e-7;
  // Refits without the observations the previous fit explains worst: residual |I - model|
  // (summed over channels, relative to the observations' mean |I|) above both
  // min_outlier_residual and its median + outlier_mads * 1.4826 MAD. Normals from depth are
  // wrong at silhouettes and creases, and a light of many directions bends to such pixels where
  // an order-2 SH light cannot. 0 rounds: no refit.
  int outlier_rounds = 1;
  double outlier_mads = 3.0;
  double min_outlier_residual = 0.1;
  bool IsValid(std::string* why) const;
};

// The fitted sources with a non-zero weight in any channel.
struct NonNegativeLight {
  std::vector<Eigen::Vector3d> directions;  // unit, camera frame, from the surface toward the source
  std::vector<Eigen::Vector3d> irradiance;  // RGB, on a plane facing the source; >= 0
  Eigen::Vector3d Irradiance(const Eigen::Vector3d& n) const;
  // The same light projected onto SH to order 2 (radiance coefficients, processing/sh.h).
  ShRgb ToSh() const;
};

struct NonNegativeLightSummary {
  bool usable = false;  // false: no light (see message)
  int observation_count = 0;
  int outlier_count = 0;               // observations the last refit left out
  int active_direction_count = 0;      // directions with a positive weight in some channel
  double relative_rms_residual = 0.0;  // rms(I - model) / rms(I) over the observations
  int iterations = 0;                  // active-set steps, summed over the channels
  bool converged = false;              // every channel met the optimality test
  std::string message;
  std::string BriefReport() const;
};

struct NonNegativeLightResult {
  NonNegativeLight light;
  NonNegativeLightSummary summary;
};

// Known albedo (ShObservation::albedo). Throws InvalidArgumentError for invalid options; too
// few observations or no light in the pixels is a summary with usable = false.
NonNegativeLightResult FitNonNegativeLight(const std::vector<ShObservation>& observations,
                                           const NonNegativeLightOptions& options = {});

// Unknown albedo, one per segment (ShObservation::segment), as the SH fit with unknown albedo
// (sh_fit.h) leaves it: starting from `segment_albedo` (that fit's, whose light and albedos
// agree), the non-negative light and the segments' albedos are updated in turn `rounds` times
// (albedo: sum I E / sum E^2 per segment and channel), the reference segment keeping its
// albedo, which fixes each channel's scale as the SH fit's does. Segments whose albedo is
// zero or that have no observations are left out.
struct NonNegativeSegmentFitResult {
  NonNegativeLightResult fit;                   // the last light step's
  std::vector<Eigen::Vector3d> segment_albedo;  // after the last albedo step
};
NonNegativeSegmentFitResult FitNonNegativeLightSegments(const std::vector<ShObservation>& observations,
                                                        std::vector<Eigen::Vector3d> segment_albedo,
                                                        int reference_segment, int rounds,
                                                        const NonNegativeLightOptions& options = {});

// Shared albedo (FitShFrameSharedAlbedo, sh_pipeline.h): the light with each segment's albedo
// (another frame's, e.g. FitNonNegativeLightSegments') as known. Observations of segments whose
// albedo is zero are left out; a segment without an albedo throws InvalidArgumentError.
NonNegativeLightResult FitNonNegativeLightKnownSegments(const std::vector<ShObservation>& observations,
                                                        const std::vector<Eigen::Vector3d>& segment_albedo,
                                                        const NonNegativeLightOptions& options = {});

// The grid FitNonNegativeLight uses: `count` unit directions on a Fibonacci sphere.
std::vector<Eigen::Vector3d> FibonacciDirections(int count);

}  // namespace relume::processing
