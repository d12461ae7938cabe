// Diffuse interreflection for the SH bounces suite (bench/sh_suite.cc): the light a scene of
// Lambertian spheres and boxes before a wall (processing/testing/synthetic_scene.h) reflects onto
// itself, added to the unoccluded direct light RenderPrimitives gives. Independent of every
// method it tests: its own rays, the scene's true geometry, albedo and light.
//
// A surface point's indirect irradiance is estimated by path tracing: `paths` cosine-weighted
// rays (a sqrt x sqrt stratified grid for the first direction, shifted by a random offset per
// point; later directions at random), each followed for up to `bounces` surfaces. With a
// cosine-weighted direction (pdf cos / pi), E = integral of L cos = pi E[L], and a Lambertian
// hit reflects L = rho / pi (E_direct + E_indirect), so one path contributes
//   rho_1 E_d(n_1) + rho_1 rho_2 E_d(n_2) + ... + rho_1 ... rho_b E_d(n_b),
// E_d the light's irradiance at the hit's normal (the suite's lights are distant and, as in
// every SH suite, unoccluded: nothing casts a shadow, so a ray that meets nothing brings no
// more than E_d already counts). The wall is the infinite plane z = wall_depth_m facing the
// camera; a ray meeting the back of a surface brings nothing.
// Deterministic for a seed, whatever the thread count.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "processing/testing/synthetic_scene.h"

namespace relume::bench {

struct PrimitiveBouncesOptions {
  int bounces = 3;         // >= 1: surfaces a path may meet after the one it starts from
  int paths = 1024;        // >= 1 per point (rounded up to a square)
  std::uint64_t seed = 1;  // the random shifts and later directions
  int threads = 0;         // 0: DefaultThreads()
  bool IsValid(std::string* why) const;
};

// The indirect irradiance (RGB, W m^-2 in the light's units) at `point` (camera frame, metres)
// on a surface with unit `normal`; `point_seed` varies the random shift per point.
Eigen::Vector3d PrimitiveIndirectIrradiance(const processing::testing::PrimitiveScene& scene,
                                            const processing::testing::IrradianceFunction& irradiance,
                                            const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                                            const PrimitiveBouncesOptions& options, std::uint64_t point_seed);

// What AddPrimitiveInterreflection added.
struct PrimitiveBouncesSummary {
  int pixels = 0;                  // object pixels given their indirect light
  double indirect_share_mean = 0;  // mean over them of |E_indirect| / |E_direct + E_indirect| (green)
  double seconds = 0;
};

// Adds rho / pi E_indirect to frame->radiance and E_indirect to frame->irradiance on the pixels of
// frame->object_mask (the wall's pixels, which no SH fit reads, keep their direct light), for the
// frame RenderPrimitives made of `scene` under `irradiance`. InvalidArgumentError on invalid options.
PrimitiveBouncesSummary AddPrimitiveInterreflection(const processing::testing::PrimitiveScene& scene,
                                                    const processing::testing::IrradianceFunction& irradiance,
                                                    const PrimitiveBouncesOptions& options,
                                                    processing::testing::SyntheticFrame* frame);

}  // namespace relume::bench
