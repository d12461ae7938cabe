#include "bench/primitive_bounces.h"

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "core/error.h"
#include "core/parallel.h"
#include "processing/radiosity/geometry.h"

namespace relume::bench {
namespace {

namespace pt = processing::testing;

// SplitMix64: a small, fast generator whose stream depends only on its seed.
class SplitMix {
 public:
  explicit SplitMix(std::uint64_t seed) : state_(seed) {}
  std::uint64_t Next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }  // [0, 1)

 private:
  std::uint64_t state_;
};

struct Hit {
  double t = std::numeric_limits<double>::infinity();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // outward, against the ray
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();
};

constexpr double kMinT = 1e-7;  // metres: a ray does not meet the surface it leaves

// The nearest surface a ray from `o` along unit `d` meets from the front, if any.
std::optional<Hit> Intersect(const pt::PrimitiveScene& scene, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  Hit best;
  for (const pt::Primitive& p : scene.objects) {
    if (p.kind == pt::Primitive::Kind::kSphere) {
      const Eigen::Vector3d oc = o - p.centre;
      const double b = oc.dot(d), c = oc.squaredNorm() - p.radius * p.radius;
      const double disc = b * b - c;
      if (disc < 0.0 || c < 0.0) continue;  // missed, or starts inside (meets only the back)
      const double t = -b - std::sqrt(disc);
      if (t > kMinT && t < best.t) {
        best.t = t;
        best.normal = (o + t * d - p.centre) / p.radius;
        best.albedo = p.albedo;
      }
    } else {
      // Slabs in the box's frame; the entering face is the hit.
      const Eigen::Vector3d ob = p.camera_from_box.transpose() * (o - p.centre);
      const Eigen::Vector3d db = p.camera_from_box.transpose() * d;
      double t_near = -std::numeric_limits<double>::infinity(), t_far = std::numeric_limits<double>::infinity();
      int axis = -1;
      double sign = 0.0;
      bool missed = false;
      for (int a = 0; a < 3 && !missed; ++a) {
        const double h = p.half_extents(a);
        if (std::abs(db(a)) < 1e-15) {
          missed = std::abs(ob(a)) > h;
          continue;
        }
        double t0 = (-h - ob(a)) / db(a), t1 = (h - ob(a)) / db(a);
        double s = -1.0;  // entering through the -h face when moving toward +
        if (t0 > t1) {
          std::swap(t0, t1);
          s = 1.0;
        }
        if (t0 > t_near) {
          t_near = t0;
          axis = a;
          sign = s;
        }
        t_far = std::min(t_far, t1);
        missed = t_near > t_far;
      }
      if (missed || axis < 0 || !(t_near > kMinT) || t_near >= best.t) continue;
      best.t = t_near;
      Eigen::Vector3d nb = Eigen::Vector3d::Zero();
      nb(axis) = sign;
      best.normal = p.camera_from_box * nb;
      best.albedo = p.albedo;
    }
  }
  if (scene.with_wall && d.z() > 0.0) {
    const double t = (scene.wall_depth_m - o.z()) / d.z();
    if (t > kMinT && t < best.t) {
      best.t = t;
      best.normal = Eigen::Vector3d(0, 0, -1);
      best.albedo = scene.wall_albedo;
    }
  }
  if (!std::isfinite(best.t)) return std::nullopt;
  return best;
}

}  // namespace

bool PrimitiveBouncesOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (bounces < 1) return fail("bounces must be >= 1");
  if (paths < 1) return fail("paths must be >= 1");
  if (threads < 0) return fail("threads must be >= 0");
  return true;
}

Eigen::Vector3d PrimitiveIndirectIrradiance(const pt::PrimitiveScene& scene, const pt::IrradianceFunction& irradiance,
                                            const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                                            const PrimitiveBouncesOptions& options, std::uint64_t point_seed) {
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(options.paths))));
  SplitMix random(options.seed * 0x2545f4914f6cdd1dull ^ point_seed);
  const double shift_u = random.Uniform(), shift_v = random.Uniform();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      double u1 = (i + shift_u) / side, u2 = (j + shift_v) / side;
      Eigen::Vector3d o = point, n = normal, throughput = Eigen::Vector3d::Ones();
      for (int bounce = 0; bounce < options.bounces; ++bounce) {
        if (bounce > 0) {
          u1 = random.Uniform();
          u2 = random.Uniform();
        }
        const Eigen::Vector3d d = radiosity::CosineHemisphereDirection(n, u1, u2);
        const std::optional<Hit> hit = Intersect(scene, o + 1e-6 * n, d);
        if (!hit) break;
        throughput = throughput.cwiseProduct(hit->albedo);
        sum += throughput.cwiseProduct(irradiance(hit->normal));
        o = o + 1e-6 * n + hit->t * d;
        n = hit->normal;
      }
    }
  }
  return sum / static_cast<double>(side * side);
}

PrimitiveBouncesSummary AddPrimitiveInterreflection(const pt::PrimitiveScene& scene,
                                                    const pt::IrradianceFunction& irradiance,
                                                    const PrimitiveBouncesOptions& options, pt::SyntheticFrame* frame) {
  ThrowIfInvalid(options, "primitive interreflection");
  const auto start = std::chrono::steady_clock::now();
  const int width = frame->radiance.width(), height = frame->radiance.height();
  std::vector<double> share(static_cast<std::size_t>(width) * height, -1.0);
  ParallelForEach(
      0, height,
      [&](std::int64_t row) {
        const int v = static_cast<int>(row);
        for (int u = 0; u < width; ++u) {
          if (!frame->object_mask.at<std::uint8_t>(v, u)) continue;
          const float z = frame->depth_m.at<float>(v, u);
          const cv::Vec3f nf = frame->normal_in_camera.at<cv::Vec3f>(v, u);
          const cv::Vec3f rho = frame->albedo.at<cv::Vec3f>(v, u);
          if (!std::isfinite(z) || !std::isfinite(nf[0])) continue;
          const Eigen::Vector3d point = scene.intrinsics.Unproject({u + 0.5, v + 0.5}) * z;
          const Eigen::Vector3d n = Eigen::Vector3d(nf[0], nf[1], nf[2]).normalized();
          const Eigen::Vector3d e = PrimitiveIndirectIrradiance(scene, irradiance, point, n, options,
                                                                static_cast<std::uint64_t>(v) * width + u);
          cv::Vec3f& l = frame->radiance.pixels.at<cv::Vec3f>(v, u);
          cv::Vec3f& ir = frame->irradiance.at<cv::Vec3f>(v, u);
          const double direct = ir[1];
          for (int c = 0; c < 3; ++c) {
            l[c] += static_cast<float>(rho[c] * e(c) / std::numbers::pi);
            ir[c] += static_cast<float>(e(c));
          }
          share[static_cast<std::size_t>(v) * width + u] = direct + e(1) > 0.0 ? e(1) / (direct + e(1)) : 0.0;
        }
      },
      options.threads);
  PrimitiveBouncesSummary s;
  double total = 0.0;
  for (double x : share) {
    if (x < 0.0) continue;
    total += x;
    ++s.pixels;
  }
  s.indirect_share_mean = s.pixels > 0 ? total / s.pixels : 0.0;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

}  // namespace relume::bench
