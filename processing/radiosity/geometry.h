// Geometry kernels for radiosity: deterministic sampling of triangles and the hemisphere, the
// analytic point-to-polygon form factor, and an Embree ray caster for visibility.
//
// Conventions: see scene.h (metres, one-sided triangles with counter-clockwise fronts).
// Form factor F(dx -> polygon) is the fraction of the power leaving a Lambertian
// differential area at x (normal n) that arrives at the polygon, ignoring occlusion:
// F = 1/(2 pi) * sum_i angle(g_i, g_i+1) * n . unit(g_i x g_i+1), g_i = vertex_i - x, with the
// polygon first clipped to the half-space in front of x. All sampling is deterministic
// (Hammersley points with fixed rotations): the same inputs give the same numbers.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "processing/radiosity/scene.h"

namespace relume::radiosity {

struct Triangle {
  Eigen::Vector3d v0, v1, v2;
  Eigen::Vector3d Normal() const;  // unit; zero for a degenerate triangle
  double Area() const;
  Eigen::Vector3d Centroid() const { return (v0 + v1 + v2) / 3.0; }
  double LongestEdge() const;
  // Maps (u, v) in [0, 1)^2 to a uniformly distributed point on the triangle.
  Eigen::Vector3d PointAt(double u, double v) const;
};

// Point k of an n-point 2D Hammersley set shifted by (shift_u, shift_v) modulo 1.
Eigen::Vector2d Hammersley(int k, int n, double shift_u = 0.0, double shift_v = 0.0);

// Cosine-weighted unit direction about `normal` for the sample (u, v) in [0, 1)^2.
Eigen::Vector3d CosineHemisphereDirection(const Eigen::Vector3d& normal, double u, double v);

// Unoccluded form factor from a differential area at x with unit normal n to the convex planar
// polygon `vertices` (3 or 4 vertices). The polygon counts only when x lies in front of it
// (one-sided emitter with unit normal `polygon_normal`). Always finite, in [0, 1].
double PointToPolygonFormFactor(const Eigen::Vector3d& x, const Eigen::Vector3d& n, const Eigen::Vector3d* vertices,
                                int vertex_count, const Eigen::Vector3d& polygon_normal);
double PointToTriangleFormFactor(const Eigen::Vector3d& x, const Eigen::Vector3d& n, const Triangle& triangle);

// Occlusion queries against a mesh, with Embree 3 (one build thread). Not copyable; not for
// concurrent use (it counts the rays it casts).
class RayCaster {
 public:
  explicit RayCaster(const Mesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  // True when the open segment from `from` to `to` hits a triangle. Both ends are moved off
  // their surfaces by `offset_m` along the given normals (pass zero normals for free points).
  bool SegmentOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal, const Eigen::Vector3d& to,
                       const Eigen::Vector3d& to_normal) const;
  // True when the ray from `from` (moved off its surface) along unit `dir` hits anything.
  bool RayOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal, const Eigen::Vector3d& dir) const;
  // Nearest hit along the ray: the triangle index, or -1; distance in *t_m.
  int Intersect(const Eigen::Vector3d& from, const Eigen::Vector3d& dir, double* t_m) const;

  double offset_m() const { return offset_m_; }
  long long rays_cast() const { return rays_cast_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double offset_m_ = 1e-6;
  mutable long long rays_cast_ = 0;
};

}  // namespace relume::radiosity
