#include "processing/radiosity/direct_light.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/error.h"

namespace relume::radiosity {
namespace {

constexpr double kShiftU = 0.1234, kShiftV = 0.6180;  // fixed rotation for light-side samples

struct Accumulated {
  Rgb shaded = Rgb::Zero();
  Rgb unshaded = Rgb::Zero();
};

// Irradiance at point x (normal n) from every light, with and without occlusion.
void AddLights(const Eigen::Vector3d& x, const Eigen::Vector3d& n, int k, int samples, const RayCaster& caster,
               const Lighting& lighting, const DirectLightOptions& options, Accumulated* acc) {
  for (const PointLight& light : lighting.point_lights) {
    const Eigen::Vector3d d = light.position_m - x;
    const double r2 = d.squaredNorm();
    if (!(r2 > 1e-18)) continue;
    const double r = std::sqrt(r2);
    const double cos_x = n.dot(d) / r;
    if (cos_x <= 0.0) continue;
    const double spot = light.SpotFactor(-d / r);
    if (spot <= 0.0) continue;
    const Rgb e = light.intensity_w_per_sr * (spot * cos_x / r2);
    acc->unshaded += e;
    if (!caster.SegmentOccluded(x, n, light.position_m, Eigen::Vector3d::Zero())) acc->shaded += e;
  }
  for (const AreaLight& light : lighting.area_lights) {
    const Eigen::Vector3d v[4] = {light.corner_m, light.corner_m + light.edge_u_m,
                                  light.corner_m + light.edge_u_m + light.edge_v_m, light.corner_m + light.edge_v_m};
    const Eigen::Vector3d light_normal = light.edge_u_m.cross(light.edge_v_m).normalized();
    const double f = PointToPolygonFormFactor(x, n, v, 4, light_normal);
    if (f <= 0.0) continue;
    const Rgb e = std::numbers::pi * f * light.radiance;
    acc->unshaded += e;
    const Eigen::Vector2d uv = Hammersley(k, samples, kShiftU, kShiftV);
    const Eigen::Vector3d y = light.corner_m + uv.x() * light.edge_u_m + uv.y() * light.edge_v_m;
    if (n.dot(y - x) > 0.0 && !caster.SegmentOccluded(x, n, y, Eigen::Vector3d::Zero())) acc->shaded += e;
  }
  for (const SunSky& sky : lighting.sun_sky) {
    const double cos_sun = n.dot(sky.sun_dir_in_scene);
    if (cos_sun > 0.0 && sky.sun_dir_in_scene.z() > 0.0 && sky.sun_irradiance_normal.maxCoeff() > 0.0) {
      const Rgb e = sky.sun_irradiance_normal * cos_sun;
      acc->unshaded += e;
      if (!caster.RayOccluded(x, n, sky.sun_dir_in_scene)) acc->shaded += e;
    }
    if (sky.sky_radiance.maxCoeff() > 0.0) {
      // Cosine-weighted directions: E = pi L * (fraction of them that reach the open sky).
      const int m = options.sky_directions;
      int up = 0, open = 0;
      for (int j = 0; j < m; ++j) {
        const Eigen::Vector2d uv = Hammersley(j, m, 0.37 * k, 0.71 * k);
        const Eigen::Vector3d dir = CosineHemisphereDirection(n, uv.x(), uv.y());
        if (dir.z() <= 0.0) continue;  // below the horizon: ground, not sky
        ++up;
        if (!caster.RayOccluded(x, n, dir)) ++open;
      }
      acc->unshaded += std::numbers::pi * sky.sky_radiance * (static_cast<double>(up) / m);
      acc->shaded += std::numbers::pi * sky.sky_radiance * (static_cast<double>(open) / m);
    }
  }
}

}  // namespace

bool DirectLightOptions::IsValid(std::string* why) const {
  if (samples_per_patch < 1 || samples_per_patch > 4096) {
    if (why) *why = "samples_per_patch must be in [1, 4096]";
    return false;
  }
  if (sky_directions < 1 || sky_directions > 65536) {
    if (why) *why = "sky_directions must be in [1, 65536]";
    return false;
  }
  return true;
}

DirectLight ComputeDirectLight(const PatchHierarchy& hierarchy, const RayCaster& caster, const Lighting& lighting,
                               const DirectLightOptions& options) {
  ThrowIfInvalid(options, "direct light options");
  ThrowIfInvalid(lighting, "lighting");
  const long long rays_before = caster.rays_cast();
  DirectLight out;
  out.irradiance.assign(hierarchy.LeafCount(), Rgb::Zero());
  out.visible_fraction.assign(hierarchy.LeafCount(), 1.0);
  const int s = options.samples_per_patch;
  for (int p = 0; p < hierarchy.LeafCount(); ++p) {
    const Node& node = hierarchy.leaf(p);
    Accumulated acc;
    for (int k = 0; k < s; ++k) {
      const Eigen::Vector2d uv = s == 1 ? Eigen::Vector2d(0.5, 0.5) : Hammersley(k, s);
      const Eigen::Vector3d x = s == 1 ? node.centroid : node.triangle.PointAt(uv.x(), uv.y());
      AddLights(x, node.normal, k, s, caster, lighting, options, &acc);
    }
    out.irradiance[p] = acc.shaded / s;
    const double unshaded = acc.unshaded.sum();
    out.visible_fraction[p] = unshaded > 0.0 ? std::clamp(acc.shaded.sum() / unshaded, 0.0, 1.0) : 1.0;
  }
  out.rays = caster.rays_cast() - rays_before;
  return out;
}

Rgb DirectIrradianceAtPoint(const RayCaster& caster, const Lighting& lighting, const Eigen::Vector3d& x,
                            const Eigen::Vector3d& n, const DirectLightOptions& options, int sample_index,
                            int sample_count, Rgb* unshaded) {
  RELUME_CHECK(sample_count >= 1 && sample_index >= 0);
  Accumulated acc;
  AddLights(x, n, sample_index, sample_count, caster, lighting, options, &acc);
  if (unshaded != nullptr) *unshaded = acc.unshaded;
  return acc.shaded;
}

DirectLightAtPoints ComputeDirectLightAtPoints(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                               const Lighting& lighting,
                                               const std::vector<std::vector<Eigen::Vector3f>>& points_per_patch,
                                               const DirectLightOptions& options) {
  ThrowIfInvalid(options, "direct light options");
  ThrowIfInvalid(lighting, "lighting");
  const int n = hierarchy.LeafCount();
  if (static_cast<int>(points_per_patch.size()) != n) {
    throw InvalidArgumentError("direct light at points: " + std::to_string(points_per_patch.size()) +
                               " point lists for " + std::to_string(n) + " patches");
  }
  const long long rays_before = caster.rays_cast();
  DirectLightAtPoints out;
  out.irradiance.assign(n, Rgb::Zero());
  out.visible_fraction.assign(n, 1.0);
  out.has_points.assign(n, false);
  for (int p = 0; p < n; ++p) {
    const std::vector<Eigen::Vector3f>& points = points_per_patch[p];
    if (points.empty()) continue;
    const Node& node = hierarchy.leaf(p);
    Accumulated acc;
    const int count = static_cast<int>(points.size());
    for (int k = 0; k < count; ++k) {
      const Eigen::Vector3d x = points[k].cast<double>();
      if (!x.allFinite())
        throw InvalidArgumentError("direct light at points: a point of patch " + std::to_string(p) + " is not finite");
      AddLights(x, node.normal, k, count, caster, lighting, options, &acc);
    }
    out.irradiance[p] = acc.shaded / count;
    const double unshaded = acc.unshaded.sum();
    out.visible_fraction[p] = unshaded > 0.0 ? std::clamp(acc.shaded.sum() / unshaded, 0.0, 1.0) : 1.0;
    out.has_points[p] = true;
  }
  out.rays = caster.rays_cast() - rays_before;
  return out;
}

double LightVisibilityOverDisc(const PatchHierarchy& hierarchy, int patch, const RayCaster& caster,
                               const Lighting& lighting, double radius_m, int samples) {
  const Node& node = hierarchy.leaf(patch);
  const Eigen::Vector3d n = node.normal;
  const Eigen::Vector3d t = (node.triangle.v1 - node.triangle.v0).normalized();
  const Eigen::Vector3d b = n.cross(t);
  DirectLightOptions options;
  options.sky_directions = 8;
  double lit = 0.0;
  for (int k = 0; k < samples; ++k) {
    const Eigen::Vector2d uv = Hammersley(k, samples);
    const double r = radius_m * std::sqrt(uv.x());
    const double phi = 2.0 * std::numbers::pi * uv.y();
    const Eigen::Vector3d x = node.centroid + r * (std::cos(phi) * t + std::sin(phi) * b);
    Accumulated acc;
    AddLights(x, n, k, samples, caster, lighting, options, &acc);
    const double unshaded = acc.unshaded.sum();
    lit += unshaded > 0.0 ? acc.shaded.sum() / unshaded : 1.0;
  }
  return samples > 0 ? lit / samples : 1.0;
}

}  // namespace relume::radiosity
