// Geometry kernels for radiosity: deterministic sampling of triangles and the hemisphere, and
// the analytic point-to-polygon form factor. Visibility is relume::RayCaster's
// (processing/geometry/ray_caster.h, with its offset policy), built on the mesh's geometry.
//
// Conventions: see scene.h (metres, one-sided triangles with counter-clockwise fronts).
// Form factor F(dx -> polygon) is the fraction of the power leaving a Lambertian
// differential area at x (normal n) that arrives at the polygon, ignoring occlusion:
// F = 1/(2 pi) * sum_i angle(g_i, g_i+1) * n . unit(g_i x g_i+1), g_i = vertex_i - x, with the
// polygon first clipped to the half-space in front of x. All sampling is deterministic
// (Hammersley points with fixed rotations): the same inputs give the same numbers.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "processing/geometry/ray_caster.h"
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

}  // namespace relume::radiosity
