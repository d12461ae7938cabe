// The simulated world: renders a Scene (scene.h) into the ground truth of sim/truth.h.
//
// Conventions: those of sim/truth.h (binding) and scene.h. In addition:
//  - irradiance is NaN where a pixel sees no surface (like depth, normals and albedo).
//  - radiance where a ray hits nothing is the sky's (sky.h: zero below the horizon), and
//    inside the sun's disk the sun's own radiance E_sun / Omega_sun (a 0.53 deg disk:
//    Omega = 6.7e-5 sr, so L ~ 1.5e7 W m^-2 sr^-1 for 1000 W/m^2).
//  - sun_visibility counts the sun-disk samples (RenderOptions::sun_samples, a fixed
//    stratified pattern) that are above the horizon, in front of the surface (facing normal)
//    and unoccluded. Direct sun irradiance = E_sun * mean over samples of visible * cos.
//  - sky irradiance = pi * mean over a fixed cosine-weighted pattern of L_sky * visible
//    (RenderOptions::sky_samples); exact for a uniform unoccluded sky.
//  - lamps: E = I * spot * cos / d^2 with a hard shadow ray (point sources).
//  - indirect (RenderOptions::indirect_bounces > 0): Monte Carlo with a per-pixel scrambled
//    R2 sequence seeded by RenderOptions::seed: deterministic, but noisy (docs/sim-world.md).
// Ray casting is Embree 3. Static geometry is built once; each moving object is its own
// Embree scene, instanced at its offset for the time asked. Render() is thread-safe.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/truth.h"
#include "sim/world/scene.h"
#include "sim/world/sky.h"

namespace relume::sim {

class World final : public TruthSource {
 public:
  // Checks the scene (InvalidArgumentError naming what is wrong) and builds the ray-casting
  // structures. The first form uses scene.render as the options.
  explicit World(Scene scene);
  World(Scene scene, const RenderOptions& options);
  ~World() override;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  GroundTruth Render(const PinholeCamera& camera, UtcTime time) const override;
  // At the scene's default time.
  GroundTruth Render(const PinholeCamera& camera) const { return Render(camera, scene().time); }

  // A named camera of the scene; with a size, the same pose and horizontal field of view at
  // that size. InvalidArgumentError listing the names when there is no such camera.
  PinholeCamera Camera(const std::string& name) const;
  PinholeCamera Camera(const std::string& name, int width, int height) const;
  std::vector<std::string> CameraNames() const;

  // Unit vector toward the sun's centre in the scene (ENU) frame at `time`.
  Eigen::Vector3d SunDirection(UtcTime time) const;
  // How far object `index` (into scene().objects) has moved from its described place.
  Eigen::Vector3d ObjectOffset(int index, UtcTime time) const;
  Eigen::Vector3d LampPosition(int index, UtcTime time) const;
  // The sky's order-2 SH projection (sky.h conventions), computed once.
  const ShCoefficients& SkySh() const;

  const Scene& scene() const;
  const RenderOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace relume::sim
