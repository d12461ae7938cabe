// The absolute radiance scale of a relative photograph (an EV-only camera's, a JPEG's) from
// surfaces of known reflectance in it: a ColorChecker's patches, a grey card, a reflectance
// standard. It stands in for a radiometrically calibrated camera.
//
// A Lambertian reference patch p of known albedo rho seen with relative radiance L obeys, per
// channel,   pi k L = rho (E_direct + E_indirect),
// with k the wanted scale, E_direct the lamps' irradiance at the pixels' surface points (known
// geometry and stated lamp intensities) and E_indirect the light other surfaces reflect onto it.
// E_indirect is itself measured in the photograph's units (the reflectance estimate gathers the
// observed radiosity pi k L_j of the other patches), so k is a fixed point:
//   k = median over references and channels of rho (E_direct + E_indirect(k)) / (pi L).
// It starts from the direct light alone (E_indirect = 0, a lower bound) and is solved by the
// secant method on k - f(k); each evaluation of f runs the reflectance estimate (reflectance.h)
// at that scale. The map's slope is the references' indirect share of their light (< 1), so it
// converges; with little indirect light the first step is already exact.
// The median over (patch, channel) samples keeps a mismodelled patch (a specular highlight, a
// chart patch in a shadow edge) from moving the scale; the spread of the per-sample scales is
// reported as the reference's consistency.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "processing/radiosity/reflectance.h"

namespace relume::radiosity {

// One leaf patch of known reflectance as the reference image (observation 0) saw it.
struct ReferencePatch {
  int patch = -1;                       // leaf index in the hierarchy
  Rgb albedo = Rgb::Zero();             // known reflectance (linear, the photograph's primaries)
  Rgb radiance = Rgb::Zero();           // mean relative radiance of its pixels, observation 0's units
  std::vector<Eigen::Vector3f> points;  // where those pixels' centre rays hit the patch (scene metres)
};

struct ReferenceScaleOptions {
  int max_solves = 8;                     // reflectance estimates at most
  double tolerance = 1e-3;                // stop when the scale changes by less than this, relative
  double min_albedo = 0.05;               // channels of darker references carry too little signal
  double min_irradiance_fraction = 0.05;  // references lit below this fraction of the brightest: skipped
  bool IsValid(std::string* why) const;
};

struct ReferenceScaleResult {
  double scale = 1.0;              // multiply observation 0's radiance by this (W m^-2 sr^-1)
  double direct_only_scale = 1.0;  // the first estimate, E_indirect = 0 (a lower bound)
  double relative_spread = 0.0;    // half the 16th-84th percentile range of the per-sample scales / scale
  int samples = 0;                 // (patch, channel) pairs in the median
  int patches = 0;                 // reference patches used
  double indirect_share = 0.0;     // the references' E_indirect / (E_direct + E_indirect) at the scale
  std::vector<double> history;     // the scale after each reflectance estimate
  int solves = 0;
  bool converged = false;
  std::string reason;
  double time_s = 0.0;
};

// `observations`: relative radiance per patch as EstimateReflectance takes it (observation 0 the
// reference image, the others made consistent with it by `reflectance.fit_image_scales`).
// Throws InvalidArgumentError for invalid options, references outside the hierarchy or without
// points, and when no reference channel is usable (all too dark or unlit): the message says so.
ReferenceScaleResult EstimateReferenceScale(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                            const std::vector<RadianceObservation>& observations,
                                            const std::vector<ReferencePatch>& references,
                                            const ReflectanceOptions& reflectance,
                                            const ReferenceScaleOptions& options);

}  // namespace relume::radiosity
