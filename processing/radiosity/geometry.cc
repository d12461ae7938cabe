#include "processing/radiosity/geometry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/error.h"

namespace relume::radiosity {

Eigen::Vector3d Triangle::Normal() const {
  const Eigen::Vector3d n = (v1 - v0).cross(v2 - v0);
  const double len = n.norm();
  return len > 0.0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

double Triangle::Area() const {
  return 0.5 * (v1 - v0).cross(v2 - v0).norm();
}

double Triangle::LongestEdge() const {
  return std::max({(v1 - v0).norm(), (v2 - v1).norm(), (v0 - v2).norm()});
}

Eigen::Vector3d Triangle::PointAt(double u, double v) const {
  const double a = std::sqrt(u);
  return (1.0 - a) * v0 + a * (1.0 - v) * v1 + a * v * v2;
}

Eigen::Vector2d Hammersley(int k, int n, double shift_u, double shift_v) {
  unsigned bits = static_cast<unsigned>(k);
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
  const double radical = static_cast<double>(bits) * 2.3283064365386963e-10;
  double u = (k + 0.5) / n + shift_u;
  double v = radical + 0.5 / (2.0 * n) + shift_v;
  u -= std::floor(u);
  v -= std::floor(v);
  return {u, v};
}

Eigen::Vector3d CosineHemisphereDirection(const Eigen::Vector3d& normal, double u, double v) {
  const Eigen::Vector3d helper = std::abs(normal.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d t = normal.cross(helper).normalized();
  const Eigen::Vector3d b = normal.cross(t);
  const double r = std::sqrt(u);
  const double phi = 2.0 * std::numbers::pi * v;
  const double z = std::sqrt(std::max(0.0, 1.0 - u));
  return (r * std::cos(phi) * t + r * std::sin(phi) * b + z * normal).normalized();
}

double PointToPolygonFormFactor(const Eigen::Vector3d& x, const Eigen::Vector3d& n, const Eigen::Vector3d* vertices,
                                int vertex_count, const Eigen::Vector3d& polygon_normal) {
  RELUME_CHECK(vertex_count >= 3 && vertex_count <= 4);
  // One-sided: x must lie strictly in front of the polygon's plane.
  if ((x - vertices[0]).dot(polygon_normal) <= 0.0) return 0.0;
  // Clip the polygon to the half-space in front of x (Sutherland-Hodgman, one plane).
  Eigen::Vector3d clipped[8];
  int count = 0;
  for (int i = 0; i < vertex_count; ++i) {
    const Eigen::Vector3d& a = vertices[i];
    const Eigen::Vector3d& b = vertices[(i + 1) % vertex_count];
    const double da = (a - x).dot(n);
    const double db = (b - x).dot(n);
    if (da > 0.0) clipped[count++] = a;
    if ((da > 0.0) != (db > 0.0) && da != db) {
      const double t = da / (da - db);
      clipped[count++] = a + t * (b - a);
    }
  }
  if (count < 3) return 0.0;
  double sum = 0.0;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d g0 = clipped[i] - x;
    const Eigen::Vector3d g1 = clipped[(i + 1) % count] - x;
    const Eigen::Vector3d c = g0.cross(g1);
    const double c_norm = c.norm();
    if (!(c_norm > 0.0)) continue;
    const double angle = std::atan2(c_norm, g0.dot(g1));
    sum += angle * n.dot(c) / c_norm;
  }
  const double f = std::abs(sum) / (2.0 * std::numbers::pi);
  return std::isfinite(f) ? std::clamp(f, 0.0, 1.0) : 0.0;
}

double PointToTriangleFormFactor(const Eigen::Vector3d& x, const Eigen::Vector3d& n, const Triangle& triangle) {
  const Eigen::Vector3d v[3] = {triangle.v0, triangle.v1, triangle.v2};
  return PointToPolygonFormFactor(x, n, v, 3, triangle.Normal());
}

}  // namespace relume::radiosity
