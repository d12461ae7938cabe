// Ground truth: what an ideal sensor would see and everything a scene knows, for a pinhole camera
// at an instant. The simulated world (sim/world/) renders it for its devices, tests and benchmarks;
// processing meets it only through SessionTruth, for evaluation (compare_truth, the floors), never
// as an input to a real session's results. It is here, in core, so that evaluation code can
// speak of truth without the simulator: a session's truth may come from the simulator or from an
// external renderer.
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

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/pinhole.h"
#include "core/time.h"

namespace relume {

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

// A recorded session's ground truth, for evaluation only: the pipelines compare their results
// with it (compare_truth) and run their floors on it (the method given the true radiance, normals
// or scale), and say so; nothing a real session's result depends on comes from here. Sessions of
// real devices have none. rig/session_truth.h makes one for a simulated session from the world
// it stored.
class SessionTruth : public TruthSource {
 public:
  // Identifies the truth for stage keys: a change to it recomputes the stages that compare with
  // it or run on it.
  virtual std::string Key() const = 0;
  // The camera that really took device `device_id`'s frames (the truth's, not the session's
  // calibrated one); nullopt when the truth does not know the device.
  virtual std::optional<PinholeCamera> DeviceCamera(const std::string& device_id) const = 0;
  // True Lambertian albedo of face `face` of the scene object named `object` (the object's
  // albedo unless it has one per face, e.g. a ColorChecker's patches); nullopt when the truth has
  // no object of that name.
  virtual std::optional<Eigen::Vector3d> Albedo(const std::string& object, int face) const = 0;
  // The radiance `camera` sees at `time` when the scene's lamps are replaced by one isotropic
  // point lamp at `position_m` of `intensity_w_sr` (W/sr per channel), the sun and sky as they
  // are: a relighting's truth.
  virtual RadianceImage RenderWithPointLamp(const PinholeCamera& camera, UtcTime time,
                                            const Eigen::Vector3d& position_m,
                                            const Eigen::Vector3d& intensity_w_sr) const = 0;
  // Unit vector toward the true sun's centre, ENU, at `time`.
  virtual Eigen::Vector3d SunDirection(UtcTime time) const = 0;
  // How many bounces of indirect light the truth renders (0: direct light only).
  virtual int IndirectBounces() const = 0;
};

}  // namespace relume
