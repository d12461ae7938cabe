// A procedural outdoor scene for IRM tests and benchmarks: ground, a building and a taller
// neighbour that shadows it, lit by a sun + uniform sky rendered exactly under the model the
// IRMs assume (Lambertian, distant light; the sky unoccluded as in the paper, or occluded by
// the scene with `sky_samples` > 0). Test data only; the simulated world (sim/world) is the
// full renderer.
#pragma once

#include <cmath>

#include "core/image.h"
#include "core/mesh.h"
#include "processing/geometry/ray_caster.h"

namespace relume::irm::testing {

struct OutdoorScene {
  TriangleMesh mesh;
  explicit OutdoorScene(int subdivisions = 12) {
    mesh.Append(MakeQuad({-30, -30, 0}, {60, 0, 0}, {0, 60, 0}, 8 * subdivisions));
    mesh.Append(MakeBox({-6, -3, 0}, {6, 3, 8}, subdivisions));   // the building
    mesh.Append(MakeBox({9, -2, 0}, {13, 2, 16}, subdivisions));  // the neighbour to its east
    mesh.albedo.assign(mesh.vertex_count(), Eigen::Vector3f(0.45f, 0.4f, 0.35f));
    for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
      // Some texture so that albedo is not constant (ratios must not depend on it).
      const Eigen::Vector3f& p = mesh.positions[i];
      mesh.albedo[i] = Eigen::Vector3f(0.3f + 0.2f * std::sin(p.x()), 0.35f + 0.15f * std::cos(1.3f * p.y()),
                                       0.3f + 0.1f * std::sin(0.7f * p.z() + p.x()));
    }
  }
};

struct Light {
  Eigen::Vector3f sun_dir;
  Eigen::Vector3f sun_irradiance;  // W/m^2 on a plane facing the sun
  Eigen::Vector3f sky_radiance;    // W/m^2/sr, uniform
};

inline Eigen::Vector3f SunFromAzimuthElevationDeg(float azimuth_deg, float elevation_deg) {
  const float az = azimuth_deg * 3.14159265f / 180.0f, el = elevation_deg * 3.14159265f / 180.0f;
  return {std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el)};
}

// Truth radiance per pixel: albedo x (sun fraction x sun + sky) / pi, the sky's irradiance
// that of an unoccluded tilted plane (sky_samples = 0) or pi x radiance x the point's sky view
// (SkyViewFraction with sky_samples rays). Also returns the per-pixel sun fraction (penumbra truth).
inline RadianceImage Render(const RayCaster& caster, const PinholeCamera& camera, const Light& light,
                            cv::Mat* sun_fraction = nullptr, int sun_samples = 32, int sky_samples = 0) {
  const TriangleMesh& mesh = caster.mesh();
  RadianceImage image = MakeRadianceImage(camera.intrinsics.width, camera.intrinsics.height);
  if (sun_fraction) *sun_fraction = cv::Mat(image.height(), image.width(), CV_32FC1, cv::Scalar(NAN));
  std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(image.width()));
  const float radius = 0.5f * 0.533f * 3.14159265f / 180.0f;
  for (int y = 0; y < image.height(); ++y) {
    caster.IntersectCameraRow(camera, y, 0, image.width(), hits);
    for (int x = 0; x < image.width(); ++x) {
      cv::Vec3f& out = image.pixels.at<cv::Vec3f>(y, x);
      const RayCaster::Hit& hit = hits[static_cast<std::size_t>(x)];
      if (!hit.valid) {
        for (int c = 0; c < 3; ++c) out[c] = light.sky_radiance[c];
        continue;
      }
      const Eigen::Vector3f n = caster.Interpolate(mesh.normals, hit).normalized();
      const Eigen::Vector3f p = caster.Interpolate(mesh.positions, hit);
      const Eigen::Vector3f rho = caster.Interpolate(mesh.albedo, hit);
      const float cos_sun = std::max(0.0f, n.dot(light.sun_dir));
      const float f = cos_sun > 0.0f ? SunVisibleFraction(caster, p, n, light.sun_dir, radius, sun_samples) : 1.0f;
      if (sun_fraction) sun_fraction->at<float>(y, x) = f;
      const float sky = sky_samples > 0 ? SkyViewFraction(caster, p, n, sky_samples) : 0.5f * (1 + n.z());
      const Eigen::Vector3f e = light.sun_irradiance * (f * cos_sun) + light.sky_radiance * (3.14159265f * sky);
      const Eigen::Vector3f l = rho.cwiseProduct(e) / 3.14159265f;
      for (int c = 0; c < 3; ++c) out[c] = l[c];
    }
  }
  return image;
}

}  // namespace relume::irm::testing
