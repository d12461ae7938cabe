// The IRM random outdoor suite's scene generator (bench/irm_suite.cc runs the suite): a ground
// quad and 1-5 boxes of random footprint, height, yaw and position, each with its own smooth
// albedo texture, under two random sun + sky lights, seen by two random cameras. Rendered with
// irm::testing::Render (Lambertian, sun + uniform sky occluded by the scene) and, with bounces,
// the light the surfaces reflect onto each other added (bench/interreflection_truth.h).
//
// The draw depends on the seed only, not on the image size: the source view must show both
// lit and shadowed surfaces, and the target camera must see enough of what it sees (checked on
// a fixed 80 x 56 grid of the source camera's rays, irm_suite.cc says how much), else
// the lights and cameras are drawn again from the same random stream, at most kMaxRedraws times.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "bench/interreflection_truth.h"
#include "core/image.h"
#include "core/mesh.h"
#include "core/pinhole.h"
#include "processing/geometry/ray_caster.h"
#include "processing/irm/relight.h"
#include "processing/irm/testing_scene.h"

namespace relume::bench {

// Image size and the truth renderer's quadrature for the suite's sizes.
struct IrmSuiteSize {
  int width = 0, height = 0;
  int render_sun_samples = 0;  // the truth's rays over the sun's disk per pixel
  int render_sky_samples = 0;  // the truth's sky-view rays per pixel (not the method's 144)
  // With bounces (InterreflectionOptions): rays per vertex of the radiosity solve and per pixel
  // of the final gather (its noise is in the photographs and the truth alike: it adds to every
  // error, the floor's too).
  int render_vertex_rays = 0;
  int render_pixel_rays = 0;
};
IrmSuiteSize IrmSuiteSizeFor(bool quick);

struct IrmSuiteBox {
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();
  float width = 0, depth = 0, height = 0, yaw_deg = 0;
};

struct IrmSuiteLight {
  irm::testing::Light light;
  float azimuth_deg = 0, elevation_deg = 0;
};

class IrmSuiteScene {
 public:
  static constexpr int kMaxRedraws = 16;
  // bounces = 0: direct light only; > 0: that many diffuse bounces added to the three renders.
  // The draw (geometry, lights, cameras) does not depend on it: both suites see the same scenes.
  IrmSuiteScene(std::uint64_t seed, const IrmSuiteSize& size, int bounces = 0);
  IrmSuiteScene(const IrmSuiteScene&) = delete;
  IrmSuiteScene& operator=(const IrmSuiteScene&) = delete;

  std::vector<IrmSuiteBox> boxes;
  TriangleMesh mesh;
  std::unique_ptr<RayCaster> caster;  // over `mesh`
  IrmSuiteLight source_light, target_light;
  PinholeCamera source_camera, target_camera;
  int source_box = 0, target_box = 0;  // the boxes the cameras look at
  int redraws = 0;                     // lights and cameras drawn again (kMaxRedraws at most)
  bool accepted = false;               // the last draw passed the check
  // The check's shares of the source view (fixed grid, the sun's centre ray): lit at both
  // times, shadowed (cast or attached) at either, and cast shadow at either.
  double check_lit = 0, check_shadow = 0, check_cast = 0;
  // The share of the source's surface pixels the target camera sees too, and the distinct
  // normals among them.
  double check_overlap = 0;
  int check_overlap_normals = 0;
  RadianceImage source, target, truth;  // truth: the source camera under the target light
  // Per-pixel truth sun fractions of the source camera at both times; NaN where the sun is
  // behind the surface (an attached shadow, metrics::ClassifySunRegion's shadow) or no surface.
  cv::Mat truth_source_sun, truth_target_sun;
  // With bounces: the truth's interreflection (lights 0: source, 1: target); null without.
  std::unique_ptr<InterreflectionTruth> interreflection;
  std::string Describe() const;
};

// The floor's light: an IrmSet without maps whose sun + sky model is the true one (the two
// lights' sun irradiances and sky radiances in the model's units, a uniform sky), so that
// RelightPixels gives every pixel E_target / E_source at its own normal, sun fractions and sky
// view. Bins and thresholds from `options`. With `interreflection` (lights 0: source, 1:
// target), also its true indirect light: every vertex's indirect irradiance and radiance, and
// the model's q = 1 / (pi L_sky,source), so that the ratio holds the true E_target / E_source
// with the interreflection in.
irm::IrmSet TrueLightIrms(const irm::testing::Light& source, const irm::testing::Light& target,
                          const irm::RelightOptions& options, const InterreflectionTruth* interreflection = nullptr);

}  // namespace relume::bench
