// Ray casting against a triangle mesh with Embree 3: the visibility, shadow, camera and
// form-factor rays of the processing stages (IRM, radiosity). Thread-safe after construction
// (Embree's committed scenes are; the ray counter is atomic).
//
// Conventions: rays in the mesh's frame, metres; directions need not be normalised for
// Occluded (t is in units of the direction's length) but Hit::t is a distance when they are.
// Hit::triangle indexes the mesh's triangles, in the order they were given.
//
// Offsets: one policy, applied the same way by every query that starts or ends on the surface
// (SegmentOccluded, RayOccluded, SunVisibleFraction, SkyViewFraction, SkyViewMoments):
//  - epsilon() = max(1e-6 m, 1e-5 x the diagonal of the mesh's bounding box).
//  - A surface end p with unit normal n (the side it looks out of) is lifted to
//    p + surface_lift() n, surface_lift() = 2 epsilon; an end given with a zero normal (a lamp,
//    a camera: a point in free space) is not lifted.
//  - The ray then ignores hits within surface_skip() = 4 epsilon of its start and, for a
//    segment, of its end.
// Why: vertices are float32, so Embree's hit distances and the surface points a caller passes
// (interpolated over a triangle, in double or float) lie off the triangle's plane by some float
// ulps of the scene's coordinates. An offset relative to the scene's size clears that error at
// every scale and in any unit, and 1e-5 of it (0.1 mm in a 10 m room, 1 mm on a 100 m site) is far
// below anything a caller resolves. The lift clears the point's own triangle; the skip clears
// the other surface where two meet at a crease (a wall's foot on the ground): a point a hair's
// breadth from the wall is lifted off the ground but not away from the wall, and without the
// skip a grazing ray would hit the wall at once, the point shadowing itself. The price,
// occluders closer than 4 epsilon to an end are not seen, is far below the mesh's resolution.
// The raw queries (Intersect, Occluded, CountUnoccluded, IntersectCameraRow) add nothing: they
// take [t_near, t_far] as given, for rays from free space (a camera's eye) or from points the
// caller has lifted itself by the same policy. (sim/world keeps its own Embree code and lift on
// purpose: it is the independent oracle these stages are tested against.)
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/mesh.h"
#include "core/pinhole.h"

namespace relume {

class RayCaster {
 public:
  // Keeps a reference to the mesh (for mesh() and Interpolate), which must outlive the caster;
  // Embree gets a copy of the vertices and triangles.
  explicit RayCaster(const TriangleMesh& mesh);
  // Keeps the mesh itself (for a mesh made only to be ray cast, such as radiosity's).
  explicit RayCaster(TriangleMesh&& mesh);
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

  // Surface queries, in double for callers that work in double (radiosity); the offsets are the
  // header's policy. Normals are unit, or zero for an end in free space.
  // True when something blocks the segment between the two (lifted) ends. Ends closer than
  // 2 surface_skip() after lifting see each other (no ray is cast).
  bool SegmentOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal, const Eigen::Vector3d& to,
                       const Eigen::Vector3d& to_normal) const;
  // True when the ray from `from` (lifted) along unit `direction` hits anything.
  bool RayOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal,
                   const Eigen::Vector3d& direction) const;

  const TriangleMesh& mesh() const { return mesh_; }
  // The offsets' length scale, lift and skip (the header's policy).
  float epsilon() const { return epsilon_; }
  float surface_lift() const { return 2.0f * epsilon_; }
  float surface_skip() const { return 4.0f * epsilon_; }
  // Rays traced since construction by every query (a packet counts its active rays). Safe to
  // read while other threads cast; callers measure a stage by the difference.
  std::int64_t rays_cast() const { return rays_cast_.load(std::memory_order_relaxed); }

 private:
  void Build();
  void Count(std::int64_t rays) const { rays_cast_.fetch_add(rays, std::memory_order_relaxed); }

  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<const TriangleMesh> owned_mesh_;  // set by the TriangleMesh&& constructor
  const TriangleMesh& mesh_;
  float epsilon_ = 1e-6f;
  mutable std::atomic<std::int64_t> rays_cast_{0};
};

// Fraction of the sun's disk visible from `point` on the surface (lifted along `normal`):
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

// The cosine-weighted directions SkyViewFraction and SkyViewMoments sample about a unit normal:
// `samples` rounded up to rings x sectors (about sqrt(samples) each) over the unit disk's area,
// lifted to the hemisphere; never a direction exactly in the surface's own horizontal plane when
// the normal is horizontal. The same pattern for every caller (irm/indirect.h gathers along it).
void CosineWeightedDirections(const Eigen::Vector3f& normal, int samples, std::vector<Eigen::Vector3f>* out);

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
