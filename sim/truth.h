// The contract between the simulated world (sim/world/) and everything that renders from it:
// simulated devices (sim/devices/), tests and benchmarks. A TruthSource renders, for a pinhole
// camera at an instant, what an ideal sensor would see and everything the scene knows there.
//
// Conventions (all images have the camera's size; pixel (u, v) is the ray through the pixel
// centre (u + 0.5, v + 0.5), core/pinhole.h; the world frame is the scene's ENU frame):
//  - radiance: linear RGB, W m^-2 sr^-1 per channel (RadianceUnit::kWattsPerSqmPerSr). Where a
//    ray hits nothing it is the sky's radiance in that direction (black indoors).
//  - depth_m: CV_32FC1, distance along the optical axis (camera z) to the first surface; NaN
//    where the ray hits nothing.
//  - normal_in_world: CV_32FC3, unit surface normal facing the camera; NaN where no surface.
//  - albedo: CV_32FC3, Lambertian diffuse reflectance per channel in [0, 1]; NaN where none.
//  - sun_visibility: CV_32FC1, fraction of the sun's disk visible from the surface point, in
//    [0, 1] (penumbrae are fractions); 0 where no surface or the sun is below the horizon.
//  - irradiance: CV_32FC3, total irradiance arriving at the surface, W m^-2 per channel
//    (direct sun + sky + lamps + indirect when enabled). Surfaces are Lambertian, so
//    radiance = albedo * irradiance / pi wherever there is a surface.
//  - object_id: CV_32SC1, index of the scene object hit; -1 where none.
#pragma once

#include <opencv2/core/mat.hpp>

#include "core/image.h"
#include "core/pinhole.h"
#include "core/time.h"

namespace relume::sim {

struct GroundTruth {
  RadianceImage radiance;
  cv::Mat depth_m;
  cv::Mat normal_in_world;
  cv::Mat albedo;
  cv::Mat sun_visibility;
  cv::Mat irradiance;
  cv::Mat object_id;
};

class TruthSource {
 public:
  virtual ~TruthSource() = default;
  // Renders the truth seen by `camera` at `time` (the sun, moving objects and lights follow
  // the time). Thread-safe: devices may render concurrently.
  virtual GroundTruth Render(const PinholeCamera& camera, UtcTime time) const = 0;
};

}  // namespace relume::sim
