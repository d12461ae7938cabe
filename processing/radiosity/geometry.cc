#include "processing/radiosity/geometry.h"

#include <embree3/rtcore.h>

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

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

RayCaster::RayCaster(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->device = rtcNewDevice("threads=1");
  RELUME_CHECK_MSG(impl_->device != nullptr, "Embree device creation failed");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), mesh.positions_m.size()));
  Eigen::AlignedBox3d box;
  for (size_t i = 0; i < mesh.positions_m.size(); ++i) {
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = static_cast<float>(mesh.positions_m[i][k]);
    box.extend(mesh.positions_m[i]);
  }
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned), mesh.triangles.size()));
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) indices[3 * t + k] = static_cast<unsigned>(mesh.triangles[t][k]);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->scene);
  // Float32 geometry: keep ray ends clear of their own surface by a scene-relative margin.
  const double diagonal = box.isEmpty() ? 1.0 : box.diagonal().norm();
  offset_m_ = std::max(1e-6, 2e-5 * diagonal);
}

RayCaster::~RayCaster() {
  if (impl_->scene != nullptr) rtcReleaseScene(impl_->scene);
  if (impl_->device != nullptr) rtcReleaseDevice(impl_->device);
}

namespace {

bool Occluded(RTCScene scene, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double tfar) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = static_cast<float>(origin.x());
  ray.org_y = static_cast<float>(origin.y());
  ray.org_z = static_cast<float>(origin.z());
  ray.dir_x = static_cast<float>(dir.x());
  ray.dir_y = static_cast<float>(dir.y());
  ray.dir_z = static_cast<float>(dir.z());
  ray.tnear = 0.0f;
  ray.tfar = static_cast<float>(tfar);
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(scene, &context, &ray);
  return ray.tfar < 0.0f;
}

}  // namespace

bool RayCaster::SegmentOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal,
                                const Eigen::Vector3d& to, const Eigen::Vector3d& to_normal) const {
  const Eigen::Vector3d a = from + offset_m_ * from_normal;
  const Eigen::Vector3d b = to + offset_m_ * to_normal;
  const Eigen::Vector3d d = b - a;
  const double length = d.norm();
  if (!(length > offset_m_)) return false;
  ++rays_cast_;
  return Occluded(impl_->scene, a, d / length, length - offset_m_);
}

bool RayCaster::RayOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal,
                            const Eigen::Vector3d& dir) const {
  ++rays_cast_;
  return Occluded(impl_->scene, from + offset_m_ * from_normal, dir, std::numeric_limits<float>::infinity());
}

int RayCaster::Intersect(const Eigen::Vector3d& from, const Eigen::Vector3d& dir, double* t_m) const {
  ++rays_cast_;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit hit;
  hit.ray.org_x = static_cast<float>(from.x());
  hit.ray.org_y = static_cast<float>(from.y());
  hit.ray.org_z = static_cast<float>(from.z());
  hit.ray.dir_x = static_cast<float>(dir.x());
  hit.ray.dir_y = static_cast<float>(dir.y());
  hit.ray.dir_z = static_cast<float>(dir.z());
  hit.ray.tnear = 0.0f;
  hit.ray.tfar = std::numeric_limits<float>::infinity();
  hit.ray.time = 0.0f;
  hit.ray.mask = 0xFFFFFFFFu;
  hit.ray.id = 0;
  hit.ray.flags = 0;
  hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  hit.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &hit);
  if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return -1;
  if (t_m != nullptr) *t_m = hit.ray.tfar;
  return static_cast<int>(hit.hit.primID);
}

}  // namespace relume::radiosity
