#include "processing/geometry/ray_caster.h"

#include <embree3/rtcore.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "core/error.h"

namespace relume {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayCaster::RayCaster(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()), mesh_(mesh) {
  Build();
}

RayCaster::RayCaster(TriangleMesh&& mesh)
    : impl_(std::make_unique<Impl>()),
      owned_mesh_(std::make_unique<const TriangleMesh>(std::move(mesh))),
      mesh_(*owned_mesh_) {
  Build();
}

void RayCaster::Build() {
  const TriangleMesh& mesh = mesh_;
  std::string why;
  if (!mesh.IsValid(&why)) throw InvalidArgumentError("ray caster: invalid mesh: " + why);
  impl_->device = rtcNewDevice("threads=1");
  RELUME_CHECK_MSG(impl_->device != nullptr, "Embree device creation failed");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree's own buffers (it reads one float beyond the last vertex, which they allow for).
  float* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                                3 * sizeof(float), mesh.vertex_count()));
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    for (int k = 0; k < 3; ++k) vertices[3 * i + static_cast<std::size_t>(k)] = mesh.positions[i][k];
    lo = lo.cwiseMin(mesh.positions[i]);
    hi = hi.cwiseMax(mesh.positions[i]);
  }
  unsigned* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangle_count()));
  for (std::size_t i = 0; i < mesh.triangle_count(); ++i) {
    for (int k = 0; k < 3; ++k)
      indices[3 * i + static_cast<std::size_t>(k)] = static_cast<unsigned>(mesh.triangles[i][k]);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->scene);
  // The offset policy (header): an empty mesh has nothing to clear, and gets the floor.
  const float diagonal = mesh.vertex_count() > 0 ? (hi - lo).norm() : 0.0f;
  epsilon_ = std::max(1e-6f, 1e-5f * diagonal);
}

RayCaster::~RayCaster() = default;

namespace {
void FillRay(RTCRay& ray, const Eigen::Vector3f& o, const Eigen::Vector3f& d, float t_near, float t_far) {
  ray.org_x = o.x();
  ray.org_y = o.y();
  ray.org_z = o.z();
  ray.dir_x = d.x();
  ray.dir_y = d.y();
  ray.dir_z = d.z();
  ray.tnear = t_near;
  ray.tfar = t_far;
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
}
}  // namespace

RayCaster::Hit RayCaster::Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_near,
                                    float t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rayhit;
  FillRay(rayhit.ray, origin, direction, t_near, t_far);
  rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayhit.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rayhit);
  Count(1);
  Hit hit;
  if (rayhit.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
    hit.valid = true;
    hit.t = rayhit.ray.tfar;
    hit.triangle = static_cast<int>(rayhit.hit.primID);
    hit.u = rayhit.hit.u;
    hit.v = rayhit.hit.v;
  }
  return hit;
}

bool RayCaster::Occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_near,
                         float t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  FillRay(ray, origin, direction, t_near, t_far);
  rtcOccluded1(impl_->scene, &context, &ray);
  Count(1);
  return ray.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

bool RayCaster::SegmentOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal,
                                const Eigen::Vector3d& to, const Eigen::Vector3d& to_normal) const {
  const double lift = surface_lift(), skip = surface_skip();
  const Eigen::Vector3d a = from + lift * from_normal;
  const Eigen::Vector3d b = to + lift * to_normal;
  const Eigen::Vector3d d = b - a;
  const double length = d.norm();
  if (!(length > 2.0 * skip)) return false;  // no room between the skipped ends
  return Occluded(a.cast<float>(), (d / length).cast<float>(), static_cast<float>(skip),
                  static_cast<float>(length - skip));
}

bool RayCaster::RayOccluded(const Eigen::Vector3d& from, const Eigen::Vector3d& from_normal,
                            const Eigen::Vector3d& direction) const {
  const Eigen::Vector3d a = from + static_cast<double>(surface_lift()) * from_normal;
  return Occluded(a.cast<float>(), direction.cast<float>(), surface_skip(), std::numeric_limits<float>::infinity());
}

void RayCaster::IntersectCameraRow(const PinholeCamera& camera, int y, int x0, int count, std::span<Hit> hits) const {
  RELUME_CHECK(static_cast<int>(hits.size()) >= count);
  const Eigen::Matrix3f rotation = camera.world_from_camera.linear().cast<float>();
  const Eigen::Vector3f eye = camera.world_from_camera.translation().cast<float>();
  const PinholeIntrinsics& k = camera.intrinsics;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  using Lanes = Eigen::Array<float, 16, 1>;
  // The directions of rotation * Unproject(x + 0.5, y + 0.5).cast<float>().normalized(), 16 at
  // a time with the same float operations in the same order (Eigen sums three terms as
  // a0 + (a1 + a2)), so the rays are bit for bit those of a pixel-by-pixel loop. The square
  // roots are taken lane by lane: Eigen's packet sqrt is an approximation under its fast math.
  const float dir_y = static_cast<float>(((y + 0.5) - k.cy) / k.fy);
  const float dir_y_sq_plus_one = dir_y * dir_y + 1.0f * 1.0f;
  // Embree writes only tfar and the hit: what every ray of the row shares is set once.
  alignas(64) RTCRayHit16 packet;
  for (int i = 0; i < 16; ++i) {
    packet.ray.org_x[i] = eye.x();
    packet.ray.org_y[i] = eye.y();
    packet.ray.org_z[i] = eye.z();
    packet.ray.tnear[i] = 0.0f;
    packet.ray.time[i] = 0.0f;
    packet.ray.mask[i] = 0xFFFFFFFFu;
    packet.ray.id[i] = static_cast<unsigned>(i);
    packet.ray.flags[i] = 0;
  }
  for (int start = 0; start < count; start += 16) {
    alignas(64) int valid[16];
    Eigen::Array<double, 16, 1> column;
    for (int i = 0; i < 16; ++i) {
      column[i] = (x0 + start + i) + 0.5;
      valid[i] = start + i < count ? -1 : 0;
      packet.ray.tfar[i] = std::numeric_limits<float>::infinity();
      packet.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    }
    const Lanes dir_x = ((column - k.cx) / k.fx).cast<float>();
    Lanes norm = dir_x * dir_x + dir_y_sq_plus_one;
    for (int i = 0; i < 16; ++i) norm[i] = std::sqrt(norm[i]);
    const Lanes nx = dir_x / norm, ny = dir_y / norm, nz = 1.0f / norm;
    Eigen::Map<Lanes>(packet.ray.dir_x) = rotation(0, 0) * nx + (rotation(0, 1) * ny + rotation(0, 2) * nz);
    Eigen::Map<Lanes>(packet.ray.dir_y) = rotation(1, 0) * nx + (rotation(1, 1) * ny + rotation(1, 2) * nz);
    Eigen::Map<Lanes>(packet.ray.dir_z) = rotation(2, 0) * nx + (rotation(2, 1) * ny + rotation(2, 2) * nz);
    rtcIntersect16(valid, impl_->scene, &context, &packet);
    Count(std::min(16, count - start));
    for (int i = 0; i < 16 && start + i < count; ++i) {
      Hit& hit = hits[static_cast<std::size_t>(start + i)];
      hit = Hit{};
      if (packet.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID) {
        hit.valid = true;
        hit.t = packet.ray.tfar[i];
        hit.triangle = static_cast<int>(packet.hit.primID[i]);
        hit.u = packet.hit.u[i];
        hit.v = packet.hit.v[i];
      }
    }
  }
}

int RayCaster::CountUnoccluded(const Eigen::Vector3f& origin, std::span<const Eigen::Vector3f> directions,
                               std::span<const std::uint8_t> use, float t_near, float t_far, bool coherent,
                               std::span<const float> weights, double* weight_sum) const {
  RELUME_CHECK(use.size() >= directions.size());
  RELUME_CHECK(weight_sum == nullptr || weights.size() >= directions.size());
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  const std::size_t count = directions.size();
  int unoccluded = 0;
  std::int64_t cast = 0;
  for (std::size_t start = 0; start < count; start += 16) {
    alignas(64) RTCRay16 packet;
    alignas(64) int valid[16];
    bool any = false;
    for (std::size_t i = 0; i < 16; ++i) {
      const std::size_t k = start + i;
      const bool active = k < count && use[k] != 0;
      any = any || active;
      valid[i] = active ? -1 : 0;
      const Eigen::Vector3f& d = k < count ? directions[k] : directions[start];
      packet.org_x[i] = origin.x();
      packet.org_y[i] = origin.y();
      packet.org_z[i] = origin.z();
      packet.dir_x[i] = d.x();
      packet.dir_y[i] = d.y();
      packet.dir_z[i] = d.z();
      packet.tnear[i] = t_near;
      packet.tfar[i] = t_far;
      packet.time[i] = 0.0f;
      packet.mask[i] = 0xFFFFFFFFu;
      packet.id[i] = static_cast<unsigned>(i);
      packet.flags[i] = 0;
    }
    if (!any) continue;
    rtcOccluded16(valid, impl_->scene, &context, &packet);
    for (std::size_t i = 0; i < 16; ++i) {
      cast += valid[i] != 0 ? 1 : 0;
      if (valid[i] == 0 || packet.tfar[i] < 0.0f) continue;  // inactive, or blocked (-inf)
      ++unoccluded;
      if (weight_sum != nullptr) *weight_sum += weights[start + i];
    }
  }
  Count(cast);
  return unoccluded;
}

namespace {
// Directions from one origin, sent to CountUnoccluded a few packets at a time (no allocation
// per point).
class RayBatch {
 public:
  RayBatch(const RayCaster& caster, const Eigen::Vector3f& origin, float t_near, bool coherent)
      : caster_(caster), origin_(origin), t_near_(t_near), coherent_(coherent) {}
  void Add(const Eigen::Vector3f& direction, bool use, float weight = 0.0f) {
    directions_[size_] = direction;
    use_[size_] = use ? 1 : 0;
    weights_[size_] = weight;
    if (++size_ == kCapacity) Flush();
  }
  int Unoccluded() {
    Flush();
    return unoccluded_;
  }
  // The sum of the weights of the unblocked rays.
  double UnoccludedWeight() {
    Flush();
    return weight_sum_;
  }

 private:
  static constexpr std::size_t kCapacity = 64;
  void Flush() {
    if (size_ == 0) return;
    unoccluded_ += caster_.CountUnoccluded(origin_, std::span(directions_.data(), size_), std::span(use_.data(), size_),
                                           t_near_, std::numeric_limits<float>::infinity(), coherent_,
                                           std::span(weights_.data(), size_), &weight_sum_);
    size_ = 0;
  }
  const RayCaster& caster_;
  Eigen::Vector3f origin_;
  float t_near_;
  bool coherent_;
  std::array<Eigen::Vector3f, kCapacity> directions_;
  std::array<std::uint8_t, kCapacity> use_{};
  std::array<float, kCapacity> weights_{};
  std::size_t size_ = 0;
  int unoccluded_ = 0;
  double weight_sum_ = 0.0;
};
}  // namespace

std::vector<Eigen::Vector3f> SunDiskDirections(const Eigen::Vector3f& sun_dir, float angular_radius_rad, int samples) {
  RELUME_CHECK(samples >= 1);
  // Orthonormal frame around the sun direction.
  const Eigen::Vector3f w = sun_dir.normalized();
  if (samples == 1) return {w};
  const Eigen::Vector3f helper = std::abs(w.z()) < 0.9f ? Eigen::Vector3f::UnitZ() : Eigen::Vector3f::UnitX();
  const Eigen::Vector3f u = w.cross(helper).normalized();
  const Eigen::Vector3f v = w.cross(u);
  const float tan_radius = std::tan(angular_radius_rad);
  // Stratified samples on the disk: rings of equal area, evenly spread angles (deterministic).
  const int rings = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(samples)))));
  std::vector<Eigen::Vector3f> directions;
  directions.reserve(static_cast<std::size_t>(samples));
  for (int s = 0; s < samples; ++s) {
    const int ring = s % rings;
    const int k = s / rings;
    const int per_ring = (samples + rings - 1) / rings;
    const float r = tan_radius * std::sqrt((ring + 0.5f) / rings);
    const float phi = 2.0f * std::numbers::pi_v<float> * (k + 0.5f * (ring % 2)) / per_ring;
    directions.push_back((w + u * (r * std::cos(phi)) + v * (r * std::sin(phi))).normalized());
  }
  return directions;
}

float SunVisibleFraction(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                         const Eigen::Vector3f& sun_dir, float angular_radius_rad, int samples) {
  return SunVisibleFraction(caster, point, normal, SunDiskDirections(sun_dir, angular_radius_rad, samples));
}

float SunVisibleFraction(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                         std::span<const Eigen::Vector3f> disk_directions) {
  RELUME_CHECK(!disk_directions.empty());
  // The offset policy (header): lifted off the surface, the first few epsilons skipped.
  const Eigen::Vector3f origin = point + normal * caster.surface_lift();
  RayBatch batch(caster, origin, caster.surface_skip(), /*coherent=*/true);
  // A part of the disk behind the surface counts as blocked.
  for (const Eigen::Vector3f& d : disk_directions) batch.Add(d, d.dot(normal) > 0.0f);
  return static_cast<float>(batch.Unoccluded()) / static_cast<float>(disk_directions.size());
}

void CosineWeightedDirections(const Eigen::Vector3f& normal, int samples, std::vector<Eigen::Vector3f>* out) {
  RELUME_CHECK(samples >= 1);
  // Malley's method: uniform on the unit disk, lifted to the hemisphere; one direction per cell
  // of a rings x sectors grid over the disk's area. The sectors start a quarter of a sector off
  // u (and alternate rings by half a sector): for a vertical surface u is horizontal, and
  // sectors starting on it put two directions of every other ring exactly on the horizon, where
  // they meet neither the ground nor the sky; until 2026-12-03 they did, and an open wall's sky
  // view came out 0.458 instead of 0.5 at 144 samples (0.4375 at 64). The pattern in the
  // (u, v, n) frame is computed once per thread and sample count (no trigonometry per call).
  thread_local int pattern_samples = 0;
  thread_local std::vector<Eigen::Vector3f> pattern;  // (u, v, n) coordinates
  if (pattern_samples != samples) {
    pattern.clear();
    const int rings = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(samples)))));
    const int sectors = std::max(1, (samples + rings - 1) / rings);
    for (int ring = 0; ring < rings; ++ring) {
      const float r2 = (ring + 0.5f) / static_cast<float>(rings);  // squared disk radius: equal areas
      const float r = std::sqrt(r2), lift = std::sqrt(std::max(0.0f, 1.0f - r2));
      for (int k = 0; k < sectors; ++k) {
        const float phi =
            2.0f * std::numbers::pi_v<float> * (k + 0.25f + 0.5f * (ring % 2)) / static_cast<float>(sectors);
        pattern.emplace_back(r * std::cos(phi), r * std::sin(phi), lift);
      }
    }
    pattern_samples = samples;
  }
  const Eigen::Vector3f n = normal.normalized();
  const Eigen::Vector3f helper = std::abs(n.z()) < 0.9f ? Eigen::Vector3f::UnitZ() : Eigen::Vector3f::UnitX();
  const Eigen::Vector3f u = n.cross(helper).normalized();
  const Eigen::Vector3f v = n.cross(u);
  out->resize(pattern.size());
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    (*out)[i] = u * pattern[i].x() + v * pattern[i].y() + n * pattern[i].z();
  }
}

SkyView SkyViewMoments(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                       int samples) {
  RELUME_CHECK(samples >= 1);
  const Eigen::Vector3f n = normal.normalized();
  const Eigen::Vector3f origin = point + n * caster.surface_lift();
  // The offset policy, as SunVisibleFraction. Directions over the hemisphere are not coherent.
  RayBatch batch(caster, origin, caster.surface_skip(), /*coherent=*/false);
  // The unblocked share of cosine-weighted directions estimates v, and the unblocked rays' mean
  // elevation sine (blocked ones counting 0) estimates m.
  thread_local std::vector<Eigen::Vector3f> directions;
  CosineWeightedDirections(n, samples, &directions);
  for (const Eigen::Vector3f& d : directions) batch.Add(d, d.z() > 0.0f, d.z());  // below the horizon: ground
  SkyView sky;
  sky.view = static_cast<float>(batch.Unoccluded()) / static_cast<float>(directions.size());
  sky.zenith_moment = static_cast<float>(batch.UnoccludedWeight() / static_cast<double>(directions.size()));
  return sky;
}

float SkyViewFraction(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                      int samples) {
  return SkyViewMoments(caster, point, normal, samples).view;
}

}  // namespace relume
