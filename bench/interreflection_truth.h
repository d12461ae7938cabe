// Diffuse interreflection for the IRM suite's truth (bench/irm_suite.h): the light a Lambertian
// scene under a sun and a uniform sky reflects onto itself, to add to irm::testing::Render's
// direct light. Independent of the method's gather (processing/irm/indirect.h): its own random
// directions, its own shading of what a ray meets, and the scene's true albedo and light where
// the method reads photographs.
//
// 1. Radiosity on the mesh's vertices. Every vertex casts `vertex_rays` cosine-distributed rays
//    (a sqrt x sqrt stratified grid shifted by a random offset per vertex, seeded). Rays that
//    leave upward give its sky view V; what the others meet (triangle, barycentrics) is kept.
//    Per light, the direct irradiance E_d = E_sun f max(0, n . sun) + pi L_sky V (f over
//    `sun_samples` disk rays), then Jacobi iterations
//      E_i^(k)(x) = pi / N sum_j L^(k-1)(y_j),   L^(k)(y) = rho(y) / pi (E_d(y) + E_i^(k)(y)),
//    with L^(0) = rho E_d / pi and L at a hit interpolated from its triangle's vertices, so that
//    E_i^(k) holds k bounces. A ray meeting a surface's back, or the earth beyond the mesh
//    (below the horizon), brings nothing. A vertex most of whose rays meet backs is buried (the
//    ground under a box): values at a hit are interpolated from its triangle's other vertices
//    only, so that the ground at a wall's foot does not darken toward the vertex under the wall.
// 2. A pixel's indirect irradiance, `pixel_rays` rays from the surface point its camera ray
//    meets (a random shift per pixel). At each hit the radiance is
//      rho / pi (E_sun max(0, n . sun) s + pi L_sky V + E_i^(bounces - 1))
//    with the sun's visibility s cast from the hit itself (one ray to a point of the sun's
//    disk), V and E_i interpolated. The pixel thus gets `bounces` bounces, and the sun-shadow
//    edges on the surfaces that light it are sharp, not spread over a triangle.
// Deterministic for a seed, whatever the thread count.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"
#include "processing/geometry/ray_caster.h"
#include "processing/irm/testing_scene.h"

namespace relume::bench {

struct InterreflectionOptions {
  int bounces = 3;         // >= 1: the light reaching a pixel has bounced off this many surfaces at most
  int vertex_rays = 128;   // >= 1 per vertex (rounded up to a square)
  int pixel_rays = 256;    // >= 1 per pixel (rounded up to a square)
  int sun_samples = 16;    // >= 1 disk rays for a vertex's sun fraction
  std::uint64_t seed = 1;  // the random shifts
  int threads = 0;         // 0: DefaultThreads()
  bool IsValid(std::string* why) const;
};

class InterreflectionTruth {
 public:
  // Solves the vertices' radiosity for each light (InvalidArgumentError on invalid options).
  // The caster's mesh needs albedo and normals per vertex.
  InterreflectionTruth(const RayCaster& caster, std::span<const irm::testing::Light> lights,
                       const InterreflectionOptions& options);

  // Per vertex under light `light`: the irradiance from the other surfaces with `bounces`
  // bounces, and the radiance leaving it with `bounces - 1` (what a gather from the vertices
  // must read to give `bounces`).
  const std::vector<Eigen::Vector3f>& vertex_indirect(int light) const;
  const std::vector<Eigen::Vector3f>& vertex_radiance(int light) const;

  // Adds rho / pi times each pixel's indirect irradiance (step 2) to `image`, which
  // irm::testing::Render made for the same camera and light; pixels that see no surface are
  // left as they are. Optionally the irradiance itself per pixel (CV_32FC3, NaN off the mesh).
  // Not to be called from several threads at once (it counts rays and time); it runs its own.
  void AddIndirect(const PinholeCamera& camera, int light, RadianceImage* image, cv::Mat* irradiance = nullptr) const;

  const InterreflectionOptions& options() const { return options_; }
  std::int64_t rays() const { return rays_; }  // cast so far by this object
  double seconds() const { return seconds_; }  // spent so far by this object

 private:
  struct Hit {
    int triangle = -1;
    float u = 0, v = 0;
  };
  struct PerLight {
    irm::testing::Light light;
    std::vector<Eigen::Vector3f> indirect_previous;  // E_i^(bounces - 1)
    std::vector<Eigen::Vector3f> indirect;           // E_i^(bounces)
    std::vector<Eigen::Vector3f> radiance;           // L^(bounces - 1)
  };

  const RayCaster& caster_;
  InterreflectionOptions options_;
  std::vector<float> sky_view_;          // per vertex
  std::vector<std::uint8_t> buried_;     // per vertex: inside a solid (most rays meet backs)
  std::vector<std::int64_t> hit_start_;  // CSR over vertices into hits_
  std::vector<Hit> hits_;
  std::vector<PerLight> lights_;
  mutable std::int64_t rays_ = 0;
  mutable double seconds_ = 0.0;
};

}  // namespace relume::bench
