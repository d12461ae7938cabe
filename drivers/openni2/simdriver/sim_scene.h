// The scene the simulated RGB-D driver (sim_rgbd_driver.cc) sees, defined analytically so that
// tests can check depth values exactly. Stated once here and in docs/backends-gphoto2-openni2.md.
//
// Conventions:
//  - Frames: the colour camera's frame (OpenCV: x right, y down, z forward, metres) is the
//    scene frame. The depth camera sits 25 mm to the colour camera's left, axes parallel:
//    its centre is at (-0.025, 0, 0), so p_color = p_depth + (-0.025, 0, 0).
//  - Both cameras are ideal pinholes, 58 degrees horizontal field of view, square pixels,
//    centred principal point; at W x H: f = (W / 2) / tan(29 deg), cx = W / 2, cy = H / 2.
//    Pixel (u, v) looks along ((u + 0.5 - cx) / f, (v + 0.5 - cy) / f, 1).
//  - Objects: a sphere, centre (0.1, 0, 1.5) m, radius 0.25 m; in front of a plane tilted
//    towards the bottom of the image, z = 2.0 - 0.3 y, limited to |x| <= 1.0 m. Rays that hit
//    nothing (beyond the plane's side edges) have no depth (0 in the frame).
//  - Depth = z of the first hit in the rendering camera's frame, in millimetres (rounded).
//  - Colour (RGB888): the sphere is (200, 60, 40) * (0.3 + 0.7 max(0, n . l)) with
//    l = normalise(-1, -1, -1) (light from the upper left, towards the scene); the plane is a
//    checkerboard of 0.1 m squares in (x, y), (220, 220, 220) and (40, 40, 40); no hit is black.
#pragma once

#include <cmath>
#include <optional>

namespace relume::drivers::openni2_sim {

inline constexpr double kHorizontalFovRad = 58.0 * M_PI / 180.0;
inline constexpr double kDepthCameraXInColor = -0.025;
inline constexpr double kSphereCenter[3] = {0.1, 0.0, 1.5};
inline constexpr double kSphereRadius = 0.25;

struct Hit {
  double depth_z = 0.0;  // in the rendering camera's frame
  bool sphere = false;
  double point[3] = {0, 0, 0};  // in the colour (scene) frame
  double normal[3] = {0, 0, 0};
};

// First hit along the ray through pixel (u, v) of a W x H camera whose centre is at
// (origin_x, 0, 0) in the scene frame.
inline std::optional<Hit> Trace(int u, int v, int width, int height, double origin_x) {
  const double f = (width / 2.0) / std::tan(kHorizontalFovRad / 2.0);
  const double d[3] = {(u + 0.5 - width / 2.0) / f, (v + 0.5 - height / 2.0) / f, 1.0};
  const double o[3] = {origin_x, 0.0, 0.0};
  double best_t = INFINITY;
  Hit hit;
  // Sphere: |o + t d - c|^2 = r^2.
  const double oc[3] = {o[0] - kSphereCenter[0], o[1] - kSphereCenter[1], o[2] - kSphereCenter[2]};
  const double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const double b = 2.0 * (oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2]);
  const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - kSphereRadius * kSphereRadius;
  const double disc = b * b - 4.0 * a * c;
  if (disc >= 0.0) {
    const double t = (-b - std::sqrt(disc)) / (2.0 * a);
    if (t > 0.0) {
      best_t = t;
      hit.sphere = true;
    }
  }
  // Plane z = 2 - 0.3 y  <=>  z + 0.3 y = 2.
  const double denom = d[2] + 0.3 * d[1];
  if (denom > 1e-9) {
    const double t = (2.0 - o[2] - 0.3 * o[1]) / denom;
    const double x = o[0] + t * d[0];
    if (t > 0.0 && t < best_t && std::abs(x) <= 1.0) {
      best_t = t;
      hit.sphere = false;
    }
  }
  if (!std::isfinite(best_t)) return std::nullopt;
  for (int i = 0; i < 3; ++i) hit.point[i] = o[i] + best_t * d[i];
  hit.depth_z = best_t * d[2];
  if (hit.sphere) {
    for (int i = 0; i < 3; ++i) hit.normal[i] = (hit.point[i] - kSphereCenter[i]) / kSphereRadius;
  } else {
    const double n = std::sqrt(1.0 + 0.09);
    hit.normal[0] = 0.0;
    hit.normal[1] = -0.3 / n;
    hit.normal[2] = -1.0 / n;
  }
  return hit;
}

}  // namespace relume::drivers::openni2_sim
