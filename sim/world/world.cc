#include "sim/world/world.h"

#include <embree3/rtcore.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>

#include "core/error.h"
#include "core/frames.h"
#include "core/parallel.h"
#include "sim/world/sampling.h"

namespace relume::sim {

namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void EmbreeError(void* /*user*/, RTCError code, const char* message) {
  RELUME_CHECK_MSG(code == RTC_ERROR_NONE, std::string("Embree: ") + (message ? message : "unknown error"));
}

// A point lifted off a surface along its facing normal, so rays leaving it do not hit the
// surface itself. The lift grows with the coordinates' magnitude (float precision).
Eigen::Vector3d Lift(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  return p + n * (1e-4 * (1.0 + p.cwiseAbs().maxCoeff()));
}

std::uint64_t Mix(std::uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return x;
}

}  // namespace

struct SurfaceHit {
  int object = -1;
  Eigen::Vector3d position;
  Eigen::Vector3d normal;  // unit, facing the ray's origin
  Eigen::Vector3d albedo;
  double t = 0.0;
};

// Everything that depends on the instant: built once per Render().
struct FrameState {
  RTCScene scene = nullptr;
  bool owns_scene = false;
  std::vector<int> instance_object;      // top-level instance id -> object index (-1: the static scene)
  std::vector<Eigen::Vector3d> offsets;  // per object
  bool sun_up = false;                   // some of the disk above the horizon and the sun enabled
  Eigen::Vector3d sun_direction = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> sun_samples;
  double sun_cos_radius = 1.0;
  Eigen::Vector3d sun_radiance = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> lamp_positions;
};

struct World::Impl {
  Scene scene;
  RenderOptions options;
  ShCoefficients sky_sh;
  std::vector<Eigen::Vector3d> sky_pattern;
  RTCDevice device = nullptr;
  RTCScene static_scene = nullptr;
  bool static_empty = true;
  std::vector<int> static_geometry_object;                 // geomID in the static scene -> object
  std::vector<int> moving_objects;                         // object indices with motion
  std::vector<RTCScene> moving_scenes;                     // one per moving object, in its rest place
  std::vector<std::vector<Eigen::Vector3d>> face_normals;  // per object, per triangle (unit)
  mutable std::mutex build_mutex;

  ~Impl() {
    for (RTCScene s : moving_scenes) rtcReleaseScene(s);
    if (static_scene) rtcReleaseScene(static_scene);
    if (device) rtcReleaseDevice(device);
  }

  void Build();
  RTCGeometry MakeGeometry(const SceneObject& object) const;
  FrameState Prepare(UtcTime time) const;
  void Release(FrameState& state) const {
    if (state.owns_scene) rtcReleaseScene(state.scene);
  }

  bool Intersect(const FrameState& state, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                 SurfaceHit* hit) const;
  bool Occluded(const FrameState& state, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                double max_distance) const;
  // Direct irradiance from the sun (full disk pattern), sky and lamps at a surface point.
  Eigen::Vector3d DirectIrradiance(const FrameState& state, const SurfaceHit& hit, float* sun_visibility) const;
  // A cheaper, unbiased one-sample estimate for points reached by indirect rays.
  Eigen::Vector3d DirectIrradianceOneSample(const FrameState& state, const SurfaceHit& hit, Pcg32& rng) const;
  Eigen::Vector3d IndirectIrradiance(const FrameState& state, const SurfaceHit& hit, int bounces, int samples,
                                     std::uint64_t pixel_key, Pcg32& rng) const;
  Eigen::Vector3d LampIrradiance(const FrameState& state, const SurfaceHit& hit) const;
  Eigen::Vector3d MissRadiance(const FrameState& state, const Eigen::Vector3d& unit_direction) const;
};

World::World(Scene scene) : World(scene, scene.render) {}

World::World(Scene scene, const RenderOptions& options) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!scene.IsValid(&why)) {
    throw InvalidArgumentError("scene '" + scene.name + "'" +
                               (scene.source_path.empty() ? "" : " (" + scene.source_path + ")") + ": " + why);
  }
  ThrowIfInvalid(options, "render options");
  impl_->scene = std::move(scene);
  impl_->options = options;
  impl_->sky_sh = impl_->scene.sky.ProjectSh();
  impl_->sky_pattern = CosineHemispherePattern(options.sky_samples);
  impl_->Build();
}

World::~World() = default;

const Scene& World::scene() const {
  return impl_->scene;
}
const RenderOptions& World::options() const {
  return impl_->options;
}
const ShCoefficients& World::SkySh() const {
  return impl_->sky_sh;
}

RTCGeometry World::Impl::MakeGeometry(const SceneObject& object) const {
  if (object.shape == SceneObject::Shape::kSphere) {
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    auto* point = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1));
    point[0] = static_cast<float>(object.sphere_center.x());
    point[1] = static_cast<float>(object.sphere_center.y());
    point[2] = static_cast<float>(object.sphere_center.z());
    point[3] = static_cast<float>(object.sphere_radius_m);
    rtcCommitGeometry(geometry);
    return geometry;
  }
  const TriangleMesh& mesh = object.mesh;
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), mesh.vertices.size()));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) vertices[3 * i + static_cast<std::size_t>(k)] = static_cast<float>(mesh.vertices[i][k]);
  }
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned), mesh.triangles.size()));
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k)
      indices[3 * i + static_cast<std::size_t>(k)] = static_cast<unsigned>(mesh.triangles[i][k]);
  }
  rtcCommitGeometry(geometry);
  return geometry;
}

void World::Impl::Build() {
  device = rtcNewDevice("threads=1");
  RELUME_CHECK_MSG(device != nullptr, "Embree: cannot create a device");
  rtcSetDeviceErrorFunction(device, EmbreeError, nullptr);
  static_scene = rtcNewScene(device);
  rtcSetSceneBuildQuality(static_scene, RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneFlags(static_scene, RTC_SCENE_FLAG_ROBUST);
  face_normals.resize(scene.objects.size());
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& object = scene.objects[i];
    if (object.shape != SceneObject::Shape::kSphere) {
      auto& normals = face_normals[i];
      for (const Eigen::Vector3i& t : object.mesh.triangles) {
        const Eigen::Vector3d& a = object.mesh.vertices[static_cast<std::size_t>(t[0])];
        const Eigen::Vector3d& b = object.mesh.vertices[static_cast<std::size_t>(t[1])];
        const Eigen::Vector3d& c = object.mesh.vertices[static_cast<std::size_t>(t[2])];
        const Eigen::Vector3d n = (b - a).cross(c - a);
        // A degenerate triangle cannot be hit; give it a defined normal all the same.
        normals.push_back(n.norm() > 0.0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::UnitZ());
      }
    }
    RTCGeometry geometry = MakeGeometry(object);
    if (object.motion.IsStatic()) {
      const unsigned id = rtcAttachGeometry(static_scene, geometry);
      if (static_geometry_object.size() <= id) static_geometry_object.resize(id + 1, -1);
      static_geometry_object[id] = static_cast<int>(i);
      static_empty = false;
    } else {
      RTCScene own = rtcNewScene(device);
      rtcSetSceneFlags(own, RTC_SCENE_FLAG_ROBUST);
      rtcAttachGeometry(own, geometry);
      rtcCommitScene(own);
      moving_scenes.push_back(own);
      moving_objects.push_back(static_cast<int>(i));
    }
    rtcReleaseGeometry(geometry);
  }
  rtcCommitScene(static_scene);
}

Eigen::Vector3d World::SunDirection(UtcTime time) const {
  const SunLight& sun = impl_->scene.sun;
  if (sun.direction_in_enu) return sun.direction_in_enu->normalized();
  return SunDirectionInEnu(ComputeSunPosition(impl_->scene.site, time, sun.sun_options));
}

Eigen::Vector3d World::ObjectOffset(int index, UtcTime time) const {
  RELUME_CHECK(index >= 0 && index < static_cast<int>(impl_->scene.objects.size()));
  const SceneObject& object = impl_->scene.objects[static_cast<std::size_t>(index)];
  return object.motion.OffsetAt(time, object.Anchor());
}

Eigen::Vector3d World::LampPosition(int index, UtcTime time) const {
  RELUME_CHECK(index >= 0 && index < static_cast<int>(impl_->scene.lamps.size()));
  const Lamp& lamp = impl_->scene.lamps[static_cast<std::size_t>(index)];
  return lamp.position + lamp.motion.OffsetAt(time, lamp.position);
}

std::vector<std::string> World::CameraNames() const {
  std::vector<std::string> names;
  for (const SceneCamera& camera : impl_->scene.cameras) names.push_back(camera.name);
  return names;
}

PinholeCamera World::Camera(const std::string& name) const {
  for (const SceneCamera& camera : impl_->scene.cameras) {
    if (camera.name == name) return camera.camera;
  }
  std::string names;
  for (const std::string& n : CameraNames()) names += (names.empty() ? "" : ", ") + n;
  throw InvalidArgumentError("scene '" + impl_->scene.name + "' has no camera named '" + name +
                             "'; it has: " + (names.empty() ? "none" : names));
}

PinholeCamera World::Camera(const std::string& name, int width, int height) const {
  PinholeCamera camera = Camera(name);
  if (width <= 0 || height <= 0) throw InvalidArgumentError("camera size must be positive");
  for (const SceneCamera& c : impl_->scene.cameras) {
    if (c.name == name) camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, c.horizontal_fov_rad);
  }
  std::string why;
  if (!camera.intrinsics.IsValid(&why)) {
    throw InvalidArgumentError("camera '" + name + "' at " + std::to_string(width) + "x" + std::to_string(height) +
                               ": " + why);
  }
  return camera;
}

FrameState World::Impl::Prepare(UtcTime time) const {
  FrameState state;
  state.offsets.resize(scene.objects.size(), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    state.offsets[i] = scene.objects[i].motion.OffsetAt(time, scene.objects[i].Anchor());
  }
  for (const Lamp& lamp : scene.lamps)
    state.lamp_positions.push_back(lamp.position + lamp.motion.OffsetAt(time, lamp.position));

  // The sun: its disk as a fixed stratified pattern around the centre direction.
  if (scene.sun.enabled && scene.sun.irradiance_w_m2.maxCoeff() > 0.0) {
    const Eigen::Vector3d s = scene.sun.direction_in_enu
                                  ? Eigen::Vector3d(scene.sun.direction_in_enu->normalized())
                                  : SunDirectionInEnu(ComputeSunPosition(scene.site, time, scene.sun.sun_options));
    const double radius_rad = 0.5 * scene.sun.angular_diameter_rad;
    state.sun_direction = s;
    state.sun_cos_radius = std::cos(radius_rad);
    Eigen::Vector3d e1, e2;
    OrthonormalBasis(s, &e1, &e2);
    const double r = std::tan(radius_rad);
    for (const Eigen::Vector2d& p : StratifiedDiskPattern(options.sun_samples)) {
      state.sun_samples.push_back((s + r * (p.x() * e1 + p.y() * e2)).normalized());
    }
    state.sun_up = std::sin(std::asin(std::clamp(s.z(), -1.0, 1.0)) + radius_rad) > 0.0;
    const double solid_angle_sr = 2.0 * std::numbers::pi * (1.0 - state.sun_cos_radius);
    state.sun_radiance =
        solid_angle_sr > 0.0 ? Eigen::Vector3d(scene.sun.irradiance_w_m2 / solid_angle_sr) : Eigen::Vector3d::Zero();
  }

  if (moving_objects.empty()) {
    state.scene = static_scene;
    return state;
  }
  // Moving objects: a small top-level scene of instances, one per moving object at its offset.
  std::lock_guard<std::mutex> lock(build_mutex);
  RTCScene top = rtcNewScene(device);
  auto add_instance = [&](RTCScene child, const Eigen::Vector3d& offset, int object) {
    RTCGeometry instance = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(instance, child);
    const float transform[12] = {1,
                                 0,
                                 0,
                                 0,
                                 1,
                                 0,
                                 0,
                                 0,
                                 1,
                                 static_cast<float>(offset.x()),
                                 static_cast<float>(offset.y()),
                                 static_cast<float>(offset.z())};
    rtcSetGeometryTransform(instance, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, transform);
    rtcCommitGeometry(instance);
    const unsigned id = rtcAttachGeometry(top, instance);
    rtcReleaseGeometry(instance);
    if (state.instance_object.size() <= id) state.instance_object.resize(id + 1, -1);
    state.instance_object[id] = object;
  };
  if (!static_empty) add_instance(static_scene, Eigen::Vector3d::Zero(), -1);
  for (std::size_t k = 0; k < moving_objects.size(); ++k) {
    add_instance(moving_scenes[k], state.offsets[static_cast<std::size_t>(moving_objects[k])], moving_objects[k]);
  }
  rtcCommitScene(top);
  state.scene = top;
  state.owns_scene = true;
  return state;
}

bool World::Impl::Intersect(const FrameState& state, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                            SurfaceHit* hit) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rayhit;
  rayhit.ray.org_x = static_cast<float>(origin.x());
  rayhit.ray.org_y = static_cast<float>(origin.y());
  rayhit.ray.org_z = static_cast<float>(origin.z());
  rayhit.ray.dir_x = static_cast<float>(direction.x());
  rayhit.ray.dir_y = static_cast<float>(direction.y());
  rayhit.ray.dir_z = static_cast<float>(direction.z());
  rayhit.ray.tnear = 0.0f;
  rayhit.ray.tfar = kInfinity;
  rayhit.ray.mask = 0xFFFFFFFFu;
  rayhit.ray.time = 0.0f;
  rayhit.ray.flags = 0;
  rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(state.scene, &context, &rayhit);
  if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;

  int object = -1;
  if (rayhit.hit.instID[0] == RTC_INVALID_GEOMETRY_ID) {
    object = static_geometry_object[rayhit.hit.geomID];
  } else {
    object = state.instance_object[rayhit.hit.instID[0]];
    if (object < 0) object = static_geometry_object[rayhit.hit.geomID];
  }
  RELUME_CHECK(object >= 0);
  const SceneObject& o = scene.objects[static_cast<std::size_t>(object)];
  const Eigen::Vector3d& offset = state.offsets[static_cast<std::size_t>(object)];
  hit->object = object;
  hit->t = rayhit.ray.tfar;
  hit->position = origin + hit->t * direction;
  Eigen::Vector3d normal;
  if (o.shape == SceneObject::Shape::kSphere) {
    normal = (hit->position - (o.sphere_center + offset)).normalized();
    hit->albedo = o.albedo;
  } else {
    const unsigned prim = rayhit.hit.primID;
    normal = face_normals[static_cast<std::size_t>(object)][prim];
    hit->albedo = o.albedo;
    if (!o.mesh.face_albedo.empty() && !o.mesh.face_albedo[prim].hasNaN()) hit->albedo = o.mesh.face_albedo[prim];
    if (!o.mesh.vertex_albedo.empty()) {
      const Eigen::Vector3i& t = o.mesh.triangles[prim];
      const Eigen::Vector3d& a0 = o.mesh.vertex_albedo[static_cast<std::size_t>(t[0])];
      const Eigen::Vector3d& a1 = o.mesh.vertex_albedo[static_cast<std::size_t>(t[1])];
      const Eigen::Vector3d& a2 = o.mesh.vertex_albedo[static_cast<std::size_t>(t[2])];
      if (!a0.hasNaN() && !a1.hasNaN() && !a2.hasNaN()) {
        const double u = rayhit.hit.u, v = rayhit.hit.v;
        hit->albedo = (1.0 - u - v) * a0 + u * a1 + v * a2;
      }
    }
  }
  if (normal.dot(direction) > 0.0) normal = -normal;
  hit->normal = normal;
  return true;
}

bool World::Impl::Occluded(const FrameState& state, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                           double max_distance) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = static_cast<float>(origin.x());
  ray.org_y = static_cast<float>(origin.y());
  ray.org_z = static_cast<float>(origin.z());
  ray.dir_x = static_cast<float>(direction.x());
  ray.dir_y = static_cast<float>(direction.y());
  ray.dir_z = static_cast<float>(direction.z());
  ray.tnear = 0.0f;
  ray.tfar = static_cast<float>(max_distance);
  ray.mask = 0xFFFFFFFFu;
  ray.time = 0.0f;
  ray.flags = 0;
  ray.id = 0;
  rtcOccluded1(state.scene, &context, &ray);
  return ray.tfar < 0.0f;
}

Eigen::Vector3d World::Impl::LampIrradiance(const FrameState& state, const SurfaceHit& hit) const {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  const Eigen::Vector3d origin = Lift(hit.position, hit.normal);
  for (std::size_t i = 0; i < scene.lamps.size(); ++i) {
    const Lamp& lamp = scene.lamps[i];
    const Eigen::Vector3d to_lamp = state.lamp_positions[i] - hit.position;
    const double distance = to_lamp.norm();
    if (distance <= 0.0) continue;  // a lamp on the surface lights nothing (defined, not NaN)
    const Eigen::Vector3d l = to_lamp / distance;
    const double cosine = hit.normal.dot(l);
    if (cosine <= 0.0) continue;
    const double spot = lamp.SpotFactor(-l);
    if (spot <= 0.0) continue;
    const Eigen::Vector3d from_origin = state.lamp_positions[i] - origin;
    if (Occluded(state, origin, from_origin, 1.0 - 1e-6)) continue;
    e += lamp.intensity_w_sr * (spot * cosine / (distance * distance));
  }
  return e;
}

Eigen::Vector3d World::Impl::DirectIrradiance(const FrameState& state, const SurfaceHit& hit,
                                              float* sun_visibility) const {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  const Eigen::Vector3d origin = Lift(hit.position, hit.normal);
  *sun_visibility = 0.0f;
  if (state.sun_up) {
    int visible = 0;
    double cosine_sum = 0.0;
    for (const Eigen::Vector3d& s : state.sun_samples) {
      const double cosine = hit.normal.dot(s);
      if (cosine <= 0.0 || s.z() <= 0.0) continue;
      if (Occluded(state, origin, s, kInfinity)) continue;
      ++visible;
      cosine_sum += cosine;
    }
    const double n = static_cast<double>(state.sun_samples.size());
    *sun_visibility = static_cast<float>(visible / n);
    e += scene.sun.irradiance_w_m2 * (cosine_sum / n);
  }
  if (!scene.sky.IsBlack()) {
    Eigen::Vector3d tangent, bitangent;
    OrthonormalBasis(hit.normal, &tangent, &bitangent);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& local : sky_pattern) {
      const Eigen::Vector3d d = local.x() * tangent + local.y() * bitangent + local.z() * hit.normal;
      if (d.z() < 0.0) continue;  // no sky below the horizon
      if (Occluded(state, origin, d, kInfinity)) continue;
      sum += scene.sky.Radiance(d);
    }
    e += sum * (std::numbers::pi / static_cast<double>(sky_pattern.size()));
  }
  return e + LampIrradiance(state, hit);
}

Eigen::Vector3d World::Impl::DirectIrradianceOneSample(const FrameState& state, const SurfaceHit& hit,
                                                       Pcg32& rng) const {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  const Eigen::Vector3d origin = Lift(hit.position, hit.normal);
  if (state.sun_up) {
    const Eigen::Vector3d& s = state.sun_samples[rng.NextUint() % state.sun_samples.size()];
    const double cosine = hit.normal.dot(s);
    if (cosine > 0.0 && s.z() > 0.0 && !Occluded(state, origin, s, kInfinity)) e += scene.sun.irradiance_w_m2 * cosine;
  }
  if (!scene.sky.IsBlack()) {
    Eigen::Vector3d tangent, bitangent;
    OrthonormalBasis(hit.normal, &tangent, &bitangent);
    const Eigen::Vector3d local = CosineHemisphereFromSquare(rng.NextDouble(), rng.NextDouble());
    const Eigen::Vector3d d = local.x() * tangent + local.y() * bitangent + local.z() * hit.normal;
    if (d.z() >= 0.0 && !Occluded(state, origin, d, kInfinity)) e += std::numbers::pi * scene.sky.Radiance(d);
  }
  return e + LampIrradiance(state, hit);
}

Eigen::Vector3d World::Impl::IndirectIrradiance(const FrameState& state, const SurfaceHit& hit, int bounces,
                                                int samples, std::uint64_t pixel_key, Pcg32& rng) const {
  Eigen::Vector3d tangent, bitangent;
  OrthonormalBasis(hit.normal, &tangent, &bitangent);
  const Eigen::Vector3d origin = Lift(hit.position, hit.normal);
  // A per-pixel Cranley-Patterson rotation of the R2 sequence: stratified within a pixel,
  // decorrelated between pixels, and the same on every run.
  const std::uint64_t h =
      Mix(pixel_key ^ Mix(options.seed + 0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(bounces)));
  const double shift_u = (h & 0xffffffffULL) * (1.0 / 4294967296.0);
  const double shift_v = (h >> 32) * (1.0 / 4294967296.0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int j = 0; j < samples; ++j) {
    const Eigen::Vector2d p = R2Point(static_cast<std::uint64_t>(j));
    const Eigen::Vector3d local =
        CosineHemisphereFromSquare(std::fmod(p.x() + shift_u, 1.0), std::fmod(p.y() + shift_v, 1.0));
    const Eigen::Vector3d d = local.x() * tangent + local.y() * bitangent + local.z() * hit.normal;
    SurfaceHit next;
    if (!Intersect(state, origin, d, &next)) continue;  // the sky is already counted as direct light
    Eigen::Vector3d e = DirectIrradianceOneSample(state, next, rng);
    if (bounces > 1)
      e += IndirectIrradiance(state, next, bounces - 1, 1, Mix(pixel_key + static_cast<std::uint64_t>(j) + 1), rng);
    sum += next.albedo.cwiseProduct(e) / std::numbers::pi;
  }
  return sum * (std::numbers::pi / samples);
}

Eigen::Vector3d World::Impl::MissRadiance(const FrameState& state, const Eigen::Vector3d& d) const {
  Eigen::Vector3d radiance = scene.sky.Radiance(d);
  if (state.sun_up && d.z() > 0.0 && d.dot(state.sun_direction) >= state.sun_cos_radius) radiance += state.sun_radiance;
  return radiance;
}

GroundTruth World::Render(const PinholeCamera& camera, UtcTime time) const {
  ThrowIfInvalid(camera.intrinsics, "camera intrinsics");
  const Impl& impl = *impl_;
  const int width = camera.intrinsics.width;
  const int height = camera.intrinsics.height;
  GroundTruth truth;
  truth.radiance = MakeRadianceImage(width, height, RadianceUnit::kWattsPerSqmPerSr);
  truth.depth_m = cv::Mat(height, width, CV_32FC1);
  truth.normal_in_world = cv::Mat(height, width, CV_32FC3);
  truth.albedo = cv::Mat(height, width, CV_32FC3);
  truth.sun_visibility = cv::Mat(height, width, CV_32FC1);
  truth.irradiance = cv::Mat(height, width, CV_32FC3);
  truth.object_id = cv::Mat(height, width, CV_32SC1);

  FrameState state = impl.Prepare(time);
  const Eigen::Matrix3d rotation = camera.world_from_camera.linear();
  const Eigen::Vector3d eye = camera.world_from_camera.translation();

  auto render_row = [&](int v) {
    auto* radiance = truth.radiance.pixels.ptr<cv::Vec3f>(v);
    auto* depth = truth.depth_m.ptr<float>(v);
    auto* normal = truth.normal_in_world.ptr<cv::Vec3f>(v);
    auto* albedo = truth.albedo.ptr<cv::Vec3f>(v);
    auto* visibility = truth.sun_visibility.ptr<float>(v);
    auto* irradiance = truth.irradiance.ptr<cv::Vec3f>(v);
    auto* id = truth.object_id.ptr<int>(v);
    for (int u = 0; u < width; ++u) {
      // Unnormalised, z = 1 in the camera frame: the hit distance is the depth along the axis.
      const Eigen::Vector3d direction = rotation * camera.intrinsics.Unproject({u + 0.5, v + 0.5});
      SurfaceHit hit;
      if (!impl.Intersect(state, eye, direction, &hit)) {
        const Eigen::Vector3d l = impl.MissRadiance(state, direction.normalized());
        radiance[u] = cv::Vec3f(static_cast<float>(l.x()), static_cast<float>(l.y()), static_cast<float>(l.z()));
        depth[u] = kNaN;
        normal[u] = cv::Vec3f(kNaN, kNaN, kNaN);
        albedo[u] = cv::Vec3f(kNaN, kNaN, kNaN);
        visibility[u] = 0.0f;
        irradiance[u] = cv::Vec3f(kNaN, kNaN, kNaN);
        id[u] = -1;
        continue;
      }
      float sun_visibility = 0.0f;
      Eigen::Vector3d e = impl.DirectIrradiance(state, hit, &sun_visibility);
      if (impl.options.indirect_bounces > 0) {
        const std::uint64_t key = static_cast<std::uint64_t>(v) * 0x100000001b3ULL + static_cast<std::uint64_t>(u);
        Pcg32 rng(impl.options.seed, key);
        e +=
            impl.IndirectIrradiance(state, hit, impl.options.indirect_bounces, impl.options.indirect_samples, key, rng);
      }
      const Eigen::Vector3d l = hit.albedo.cwiseProduct(e) / std::numbers::pi;
      radiance[u] = cv::Vec3f(static_cast<float>(l.x()), static_cast<float>(l.y()), static_cast<float>(l.z()));
      depth[u] = static_cast<float>(hit.t);
      normal[u] = cv::Vec3f(static_cast<float>(hit.normal.x()), static_cast<float>(hit.normal.y()),
                            static_cast<float>(hit.normal.z()));
      albedo[u] = cv::Vec3f(static_cast<float>(hit.albedo.x()), static_cast<float>(hit.albedo.y()),
                            static_cast<float>(hit.albedo.z()));
      visibility[u] = sun_visibility;
      irradiance[u] = cv::Vec3f(static_cast<float>(e.x()), static_cast<float>(e.y()), static_cast<float>(e.z()));
      id[u] = hit.object;
    }
  };

  // Rows are independent (each pixel's quasi-random sequence is keyed by its row and column),
  // so the image does not depend on the thread count. Released on the way out of an exception too.
  try {
    ParallelForEach(
        0, height, [&](std::int64_t v) { render_row(static_cast<int>(v)); }, impl.options.threads);
  } catch (...) {
    impl.Release(state);
    throw;
  }
  impl.Release(state);
  return truth;
}

}  // namespace relume::sim
