// Relighting a room whose albedo is known per patch (docs/radiosity.md, "Relighting"): every
// recorded lamp is replaced by `lighting`. The radiosity solution with that albedo gives each
// patch's indirect light; each pixel gets its patch's albedo times the new lamps' direct light at
// the pixel's own surface point plus its patch's indirect light, so the lamp's falloff and its
// shadow edges are resolved per pixel while the indirect light is patch-constant.
//
// Conventions: see scene.h. Radiance in W m^-2 sr^-1, the lamps' units (as right as the albedo
// is: an albedo known only up to a scale gives radiance off by that scale).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "processing/geometry/ray_caster.h"
#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/radiosity_solver.h"

namespace relume::radiosity {

struct RoomRelightOptions {
  DirectLightOptions direct;   // the new lamps' direct light on the patches and at the pixels
  RadiosityOptions radiosity;  // the solve with the new lamps
  bool IsValid(std::string* why) const;
};

// What a camera sees of the patches: per pixel, the leaf patch and the surface point.
struct PixelPatches {
  cv::Mat patch_ids;  // CV_32SC1, the leaf index; < 0 where the pixel sees no patch
  cv::Mat points_m;   // CV_32FC3, the pixel's surface point (scene frame, metres); NaN without one
};

struct RoomRelightResult {
  RadianceImage relit;         // per pixel; NaN where the pixel sees no patch
  std::vector<Rgb> radiosity;  // per patch, the new lamps' converged radiosity B (W m^-2)
  RadiositySummary solution;   // the solve's summary (convergence, links, energy balance)
};

// Throws InvalidArgumentError for invalid options, lighting, an albedo that is not one per leaf
// patch or pixel maps of different sizes or types.
RoomRelightResult RelightRoom(const PatchHierarchy& hierarchy, const RayCaster& caster, const std::vector<Rgb>& albedo,
                              const Lighting& lighting, const PixelPatches& pixels, const RoomRelightOptions& options);

// The per-pixel part alone, from a solution already made with the same lighting and albedo.
RadianceImage RelitPixels(const PatchHierarchy& hierarchy, const RayCaster& caster, const std::vector<Rgb>& albedo,
                          const Lighting& lighting, const std::vector<Rgb>& indirect_irradiance,
                          const PixelPatches& pixels, const DirectLightOptions& direct);

}  // namespace relume::radiosity
