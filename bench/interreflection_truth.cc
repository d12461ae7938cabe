#include "bench/interreflection_truth.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "bench/suite.h"
#include "core/error.h"
#include "core/parallel.h"

namespace relume::bench {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kSunRadius = 0.5f * 0.533f * kPi / 180.0f;
constexpr float kInfinity = std::numeric_limits<float>::infinity();

std::uint64_t Mix(std::uint64_t x) {  // one SplitMix64 step
  return SplitMix64Mix(x + 0x9e3779b97f4a7c15ULL);
}

// Two numbers in [0, 1) from a key: the per-vertex or per-pixel shift of the stratified grid.
Eigen::Vector2f Shift(std::uint64_t key) {
  const std::uint64_t h = Mix(key);
  return {static_cast<float>(h & 0xffffffULL) / 16777216.0f, static_cast<float>((h >> 32) & 0xffffffULL) / 16777216.0f};
}

// A right-handed basis around unit n (Duff et al. 2017).
void Basis(const Eigen::Vector3f& n, Eigen::Vector3f* t, Eigen::Vector3f* b) {
  const float sign = std::copysign(1.0f, n.z());
  const float a = -1.0f / (sign + n.z());
  const float c = n.x() * n.y() * a;
  *t = Eigen::Vector3f(1.0f + sign * n.x() * n.x() * a, sign * c, -sign * n.x());
  *b = Eigen::Vector3f(c, sign + n.y() * n.y() * a, -n.y());
}

// The cosine-distributed direction of cell (i, j) of a side x side grid over [0, 1)^2, shifted
// by `shift` modulo 1 (Malley's method: uniform on the disk, lifted).
Eigen::Vector3f CosineDirection(int i, int j, int side, const Eigen::Vector2f& shift, const Eigen::Vector3f& n,
                                const Eigen::Vector3f& t, const Eigen::Vector3f& b) {
  float u = (static_cast<float>(i) + 0.5f) / static_cast<float>(side) + shift.x();
  float v = (static_cast<float>(j) + 0.5f) / static_cast<float>(side) + shift.y();
  u -= std::floor(u);
  v -= std::floor(v);
  const float r = std::sqrt(u), phi = 2.0f * kPi * v;
  const float z = std::sqrt(std::max(0.0f, 1.0f - u));
  return (r * std::cos(phi) * t + r * std::sin(phi) * b + z * n).normalized();
}

int Side(int rays) {
  return static_cast<int>(std::ceil(std::sqrt(static_cast<double>(rays))));
}

// A per-vertex value at a point of a triangle, by barycentric weights over the triangle's
// vertices that are not buried (renormalised; zero when all are).
template <typename T>
T At(const TriangleMesh& mesh, const std::vector<std::uint8_t>& buried, const std::vector<T>& values, int triangle,
     float u, float v) {
  const Eigen::Vector3i& tri = mesh.triangles[static_cast<std::size_t>(triangle)];
  const float w[3] = {1.0f - u - v, u, v};
  float total = 0.0f;
  T sum = values[static_cast<std::size_t>(tri[0])] * 0.0f;
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<std::size_t>(tri[i]);
    if (buried[k]) continue;
    sum += values[k] * w[i];
    total += w[i];
  }
  return total > 0.0f ? T(sum / total) : T(sum);
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool InterreflectionOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (bounces < 1) return fail("bounces must be >= 1");
  if (vertex_rays < 1 || pixel_rays < 1 || sun_samples < 1) return fail("ray counts must be >= 1");
  if (threads < 0) return fail("threads must be >= 0");
  return true;
}

InterreflectionTruth::InterreflectionTruth(const RayCaster& caster, std::span<const irm::testing::Light> lights,
                                           const InterreflectionOptions& options)
    : caster_(caster), options_(options) {
  ThrowIfInvalid(options, "interreflection truth");
  const auto start = std::chrono::steady_clock::now();
  const TriangleMesh& mesh = caster.mesh();
  const std::size_t n = mesh.vertex_count();
  if (mesh.albedo.size() != n || mesh.normals.size() != n) {
    throw InvalidArgumentError("interreflection truth: the mesh needs an albedo and a normal per vertex");
  }
  const int side = Side(options.vertex_rays);
  const int rays = side * side;
  std::atomic<std::int64_t> cast{0};

  // Step 1: each vertex's rays, kept per vertex then packed (CSR).
  sky_view_.assign(n, 0.0f);
  buried_.assign(n, 0);
  std::vector<std::vector<Hit>> per_vertex(n);
  ParallelForEach(
      0, static_cast<std::int64_t>(n),
      [&](std::int64_t i) {
        const auto k = static_cast<std::size_t>(i);
        const Eigen::Vector3f nrm = mesh.normals[k].normalized();
        Eigen::Vector3f t, b;
        Basis(nrm, &t, &b);
        const Eigen::Vector2f shift = Shift(options.seed ^ Mix(static_cast<std::uint64_t>(i) + 0x51ed2701ULL));
        const Eigen::Vector3f origin = mesh.positions[k] + nrm * caster.surface_lift();
        int up = 0, backs = 0;
        for (int a = 0; a < side; ++a) {
          for (int c = 0; c < side; ++c) {
            const Eigen::Vector3f d = CosineDirection(a, c, side, shift, nrm, t, b);
            const RayCaster::Hit hit = caster.Intersect(origin, d, caster.surface_skip(), kInfinity);
            if (!hit.valid) {
              up += d.z() > 0.0f ? 1 : 0;
              continue;
            }
            if (caster.Interpolate(mesh.normals, hit).dot(d) >= 0.0f) {  // a back
              ++backs;
              continue;
            }
            per_vertex[k].push_back({hit.triangle, hit.u, hit.v});
          }
        }
        sky_view_[k] = static_cast<float>(up) / static_cast<float>(rays);
        buried_[k] = 2 * backs > rays ? 1 : 0;
      },
      options.threads, 256);
  cast += static_cast<std::int64_t>(n) * rays;
  hit_start_.assign(n + 1, 0);
  for (std::size_t k = 0; k < n; ++k)
    hit_start_[k + 1] = hit_start_[k] + static_cast<std::int64_t>(per_vertex[k].size());
  hits_.reserve(static_cast<std::size_t>(hit_start_[n]));
  for (std::vector<Hit>& h : per_vertex) {
    hits_.insert(hits_.end(), h.begin(), h.end());
    std::vector<Hit>().swap(h);
  }

  // Per light: direct light, then the bounces.
  const float weight = kPi / static_cast<float>(rays);
  for (const irm::testing::Light& light : lights) {
    PerLight pl;
    pl.light = light;
    const Eigen::Vector3f sun = light.sun_dir.normalized();
    const std::vector<Eigen::Vector3f> disk = SunDiskDirections(sun, kSunRadius, options.sun_samples);
    std::vector<Eigen::Vector3f> direct(n);
    ParallelForEach(
        0, static_cast<std::int64_t>(n),
        [&](std::int64_t i) {
          const auto k = static_cast<std::size_t>(i);
          const Eigen::Vector3f nrm = mesh.normals[k].normalized();
          const float cos_sun = std::max(0.0f, nrm.dot(sun));
          const float f = cos_sun > 0.0f ? SunVisibleFraction(caster, mesh.positions[k], nrm, disk) : 0.0f;
          direct[k] = light.sun_irradiance * (f * cos_sun) + light.sky_radiance * (kPi * sky_view_[k]);
        },
        options.threads, 256);
    cast += static_cast<std::int64_t>(n) * options.sun_samples;
    std::vector<Eigen::Vector3f> indirect(n, Eigen::Vector3f::Zero()), radiance(n);
    for (int k = 1; k <= options.bounces; ++k) {
      for (std::size_t v = 0; v < n; ++v) radiance[v] = mesh.albedo[v].cwiseProduct(direct[v] + indirect[v]) / kPi;
      if (k == options.bounces) {
        pl.indirect_previous = indirect;
        pl.radiance = radiance;
      }
      std::vector<Eigen::Vector3f> next(n);
      ParallelForEach(
          0, static_cast<std::int64_t>(n),
          [&](std::int64_t i) {
            const auto v = static_cast<std::size_t>(i);
            Eigen::Vector3f sum = Eigen::Vector3f::Zero();
            for (std::int64_t h = hit_start_[v]; h < hit_start_[v + 1]; ++h) {
              const Hit& hit = hits_[static_cast<std::size_t>(h)];
              sum += At(mesh, buried_, radiance, hit.triangle, hit.u, hit.v);
            }
            next[v] = weight * sum;
          },
          options.threads, 1024);
      indirect = std::move(next);
    }
    pl.indirect = std::move(indirect);
    lights_.push_back(std::move(pl));
  }
  rays_ += cast.load();
  seconds_ += SecondsSince(start);
}

const std::vector<Eigen::Vector3f>& InterreflectionTruth::vertex_indirect(int light) const {
  return lights_.at(static_cast<std::size_t>(light)).indirect;
}

const std::vector<Eigen::Vector3f>& InterreflectionTruth::vertex_radiance(int light) const {
  return lights_.at(static_cast<std::size_t>(light)).radiance;
}

void InterreflectionTruth::AddIndirect(const PinholeCamera& camera, int light, RadianceImage* image,
                                       cv::Mat* irradiance) const {
  const auto start = std::chrono::steady_clock::now();
  const PerLight& pl = lights_.at(static_cast<std::size_t>(light));
  const TriangleMesh& mesh = caster_.mesh();
  const int width = image->width(), height = image->height();
  RELUME_CHECK(width == camera.intrinsics.width && height == camera.intrinsics.height);
  if (irradiance) *irradiance = cv::Mat(height, width, CV_32FC3, cv::Scalar::all(std::nanf("")));
  const Eigen::Vector3f sun = pl.light.sun_dir.normalized();
  const std::vector<Eigen::Vector3f> disk = SunDiskDirections(sun, kSunRadius, 16);
  const int side = Side(options_.pixel_rays);
  const float weight = kPi / static_cast<float>(side * side);
  std::atomic<std::int64_t> cast{0};
  ParallelForEach(
      0, height,
      [&](std::int64_t row) {
        const int y = static_cast<int>(row);
        std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(width));
        caster_.IntersectCameraRow(camera, y, 0, width, hits);
        std::int64_t row_rays = 0;
        for (int x = 0; x < width; ++x) {
          const RayCaster::Hit& pixel = hits[static_cast<std::size_t>(x)];
          if (!pixel.valid) continue;
          const Eigen::Vector3f nrm = caster_.Interpolate(mesh.normals, pixel).normalized();
          const Eigen::Vector3f p = caster_.Interpolate(mesh.positions, pixel);
          const Eigen::Vector3f rho = caster_.Interpolate(mesh.albedo, pixel);
          Eigen::Vector3f t, b;
          Basis(nrm, &t, &b);
          const std::uint64_t key = Mix(options_.seed + 0x2545f4914f6cdd1dULL) ^
                                    Mix((static_cast<std::uint64_t>(light) << 48) ^
                                        (static_cast<std::uint64_t>(y) << 24) ^ static_cast<std::uint64_t>(x));
          const Eigen::Vector2f shift = Shift(key);
          const Eigen::Vector3f origin = p + nrm * caster_.surface_lift();
          Eigen::Vector3f sum = Eigen::Vector3f::Zero();
          int ray = 0;
          for (int a = 0; a < side; ++a) {
            for (int c = 0; c < side; ++c, ++ray) {
              const Eigen::Vector3f d = CosineDirection(a, c, side, shift, nrm, t, b);
              const RayCaster::Hit hit = caster_.Intersect(origin, d, caster_.surface_skip(), kInfinity);
              ++row_rays;
              if (!hit.valid) continue;
              const Eigen::Vector3f hn = caster_.Interpolate(mesh.normals, hit).normalized();
              if (hn.dot(d) >= 0.0f) continue;
              const Eigen::Vector3f hp = caster_.Interpolate(mesh.positions, hit);
              const float cos_sun = std::max(0.0f, hn.dot(sun));
              float s = 0.0f;
              if (cos_sun > 0.0f) {
                const Eigen::Vector3f& to_sun =
                    disk[static_cast<std::size_t>(ray + static_cast<int>(key >> 59)) % disk.size()];
                s = caster_.Occluded(hp + hn * caster_.surface_lift(), to_sun, caster_.surface_skip(), kInfinity)
                        ? 0.0f
                        : 1.0f;
                ++row_rays;
              }
              const Eigen::Vector3f e =
                  pl.light.sun_irradiance * (cos_sun * s) +
                  pl.light.sky_radiance * (kPi * At(mesh, buried_, sky_view_, hit.triangle, hit.u, hit.v)) +
                  At(mesh, buried_, pl.indirect_previous, hit.triangle, hit.u, hit.v);
              sum += At(mesh, buried_, mesh.albedo, hit.triangle, hit.u, hit.v).cwiseProduct(e) / kPi;
            }
          }
          const Eigen::Vector3f indirect = weight * sum;
          cv::Vec3f& out = image->pixels.at<cv::Vec3f>(y, x);
          for (int ch = 0; ch < 3; ++ch) out[ch] += rho[ch] * indirect[ch] / kPi;
          if (irradiance) irradiance->at<cv::Vec3f>(y, x) = cv::Vec3f(indirect.x(), indirect.y(), indirect.z());
        }
        cast += row_rays;
      },
      options_.threads, 1);
  rays_ += cast.load();
  seconds_ += SecondsSince(start);
}

}  // namespace relume::bench
