// Ray casting against a triangle mesh with Embree 3: the visibility, shadow and camera rays
// of the processing stages. Thread-safe after construction (Embree's committed scenes are).
//
// Conventions: rays in the mesh's frame, metres; directions need not be normalised for
// Occluded (t is in units of the direction's length) but Hit::t is a distance when they are.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/mesh.h"
#include "core/pinhole.h"

namespace relume {

class RayCaster {
 public:
  // The mesh must outlive the caster (its buffers are shared with Embree).
  explicit RayCaster(const TriangleMesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  struct Hit {
    bool valid = false;
    float t = 0.0f;
    int triangle = -1;
    float u = 0.0f;  // barycentric weight of the triangle's vertex 1
    float v = 0.0f;  // ... of vertex 2 (vertex 0 has 1 - u - v)
  };
  Hit Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_near, float t_far) const;
  bool Occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_near, float t_far) const;
  // Rays from one origin along each of `directions` whose `use` entry is non-zero, in packets of
  // 16 (`coherent`: the directions are close, as over the sun's disk): how many reach t_far
  // unblocked. The same answers as Occluded per ray, at a fraction of the cost per ray.
  // With `weights` (one per direction) and `weight_sum`, also adds the weights of the
  // unblocked rays to *weight_sum.
  int CountUnoccluded(const Eigen::Vector3f& origin, std::span<const Eigen::Vector3f> directions,
                      std::span<const std::uint8_t> use, float t_near, float t_far, bool coherent,
                      std::span<const float> weights = {}, double* weight_sum = nullptr) const;

  // First hits of the camera rays through the centres of pixels [x0, x0+count) of row y, in
  // packets of 16 (coherent rays are several times faster than single rays).
  void IntersectCameraRow(const PinholeCamera& camera, int y, int x0, int count, std::span<Hit> hits) const;

  // Interpolates a per-vertex attribute at a hit.
  template <typename T>
  T Interpolate(const std::vector<T>& per_vertex, const Hit& hit) const {
    const Eigen::Vector3i& tri = mesh_.triangles[static_cast<std::size_t>(hit.triangle)];
    return per_vertex[static_cast<std::size_t>(tri[0])] * (1.0f - hit.u - hit.v) +
           per_vertex[static_cast<std::size_t>(tri[1])] * hit.u + per_vertex[static_cast<std::size_t>(tri[2])] * hit.v;
  }
  const TriangleMesh& mesh() const { return mesh_; }
  // A length scale for ray offsets (1e-5 of the mesh's bounding box diagonal).
  float epsilon() const { return epsilon_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const TriangleMesh& mesh_;
  float epsilon_ = 1e-4f;
};

// Fraction of the sun's disk visible from `point` (offset along `normal` to avoid self-hits):
// `samples` stratified directions over a disk of `angular_radius_rad` around `sun_dir`.
// 0 when the sun is behind the surface.
float SunVisibleFraction(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                         const Eigen::Vector3f& sun_dir, float angular_radius_rad, int samples);
// The unit directions SunVisibleFraction samples (stratified over the disk: rings of equal
// area, evenly spread angles; the sun's centre for one sample). They depend on the sun only: a
// caller asking about many points computes them once.
std::vector<Eigen::Vector3f> SunDiskDirections(const Eigen::Vector3f& sun_dir, float angular_radius_rad, int samples);
// SunVisibleFraction with the disk's directions given (SunDiskDirections).
float SunVisibleFraction(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                         std::span<const Eigen::Vector3f> disk_directions);

// Sky view of a surface point: (1/pi) times the integral of max(0, n . w) over the directions
// w above the horizon (w_z > 0, the mesh's z is up) that no geometry blocks, i.e. the
// irradiance a uniform sky of radiance 1/pi gives it: 1 on open flat ground, (1 + n_z) / 2 on
// an open plane tilted to normal n, 1/2 on the ground at the foot of an infinitely tall and
// long wall. Estimated with `samples` cosine-weighted directions on a fixed stratified
// pattern (about sqrt(samples) x sqrt(samples) cells; the estimate is the unblocked share).
float SkyViewFraction(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                      int samples);

// The sky view v (SkyViewFraction) and, from the same rays, the sky's zenith moment
// m = (1/pi) times the integral of w_z max(0, n . w) over the same unblocked directions: the
// irradiance a sky of radiance w_z / pi gives (2/3 on open flat ground, 0 when only the horizon
// is open). A sky L(w) = a (1 + g w_z) gives E = pi a (v + g m) (processing/irm/sky_shape.h).
struct SkyView {
  float view = 0.0f;
  float zenith_moment = 0.0f;
};
SkyView SkyViewMoments(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                       int samples);

}  // namespace relume
