// Direct irradiance on every patch from point lights, area lights and a sun + uniform sky,
// with visibility by ray casting (deterministic sample points on each patch).
//
// Conventions: see scene.h. Irradiance E in W m^-2 (RGB) on the front of each patch; a patch
// facing away from a light gets 0 from it. `visible_fraction` is E divided by the same
// irradiance with every ray unoccluded (1 when nothing shades the patch; 1 too when the light
// cannot reach the patch at all, so that "in shadow" means "blocked", not "facing away").
#pragma once

#include <string>
#include <vector>

#include "processing/radiosity/geometry.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/scene.h"

namespace relume::radiosity {

struct DirectLightOptions {
  int samples_per_patch = 4;  // points on each patch (one shadow ray each per light)
  int sky_directions = 32;    // cosine-weighted directions per patch for the sky dome
  bool IsValid(std::string* why) const;
};

struct DirectLight {
  std::vector<Rgb> irradiance;           // per patch, W m^-2
  std::vector<double> visible_fraction;  // per patch in [0, 1]; see header comment
  long long rays = 0;
};

// Throws InvalidArgumentError for invalid options or lighting.
DirectLight ComputeDirectLight(const PatchHierarchy& hierarchy, const RayCaster& caster, const Lighting& lighting,
                               const DirectLightOptions& options);

// Fraction of `samples` points spread over a disc of radius `radius_m` around the patch
// centroid (in the patch plane) that see the lights (all of them unoccluded). Used for the
// distance-to-shadow-boundary confidence: values near 0 or 1 mean far from a boundary.
double LightVisibilityOverDisc(const PatchHierarchy& hierarchy, int patch, const RayCaster& caster,
                               const Lighting& lighting, double radius_m, int samples);

}  // namespace relume::radiosity
