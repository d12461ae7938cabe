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

// Direct irradiance at one point x with unit normal n from every light, with occlusion (and,
// in *unshaded, without). Area lights take their visibility ray to light sample
// `sample_index` of `sample_count` (Hammersley), as the patch estimates do.
Rgb DirectIrradianceAtPoint(const RayCaster& caster, const Lighting& lighting, const Eigen::Vector3d& x,
                            const Eigen::Vector3d& n, const DirectLightOptions& options, int sample_index = 0,
                            int sample_count = 1, Rgb* unshaded = nullptr);

// Direct irradiance averaged over given points of each patch instead of spread samples: where
// a camera's pixel rays hit the patch, so that the irradiance a photograph's mean patch radiance
// is divided by describes the same piece of surface, weighted as the pixels weight it (a point
// lamp's falloff and a shadow edge across a patch are then no error of the albedo estimate).
// `points_per_patch[p]` empty: irradiance 0 and visible fraction 1 for that patch, and
// `has_points[p]` false. Points are taken to lie on the patch (its normal is used).
struct DirectLightAtPoints {
  std::vector<Rgb> irradiance;           // per patch, W m^-2, mean over its points
  std::vector<double> visible_fraction;  // per patch, as DirectLight's
  std::vector<bool> has_points;
  long long rays = 0;
};
DirectLightAtPoints ComputeDirectLightAtPoints(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                               const Lighting& lighting,
                                               const std::vector<std::vector<Eigen::Vector3f>>& points_per_patch,
                                               const DirectLightOptions& options);

// Fraction of `samples` points spread over a disc of radius `radius_m` around the patch
// centroid (in the patch plane) that see the lights (all of them unoccluded). Used for the
// distance-to-shadow-boundary confidence: values near 0 or 1 mean far from a boundary.
double LightVisibilityOverDisc(const PatchHierarchy& hierarchy, int patch, const RayCaster& caster,
                               const Lighting& lighting, double radius_m, int samples);

}  // namespace relume::radiosity
