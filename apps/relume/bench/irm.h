// The IRM stage's scene, shared by the `irm` and `planner` benches: the analytic outdoor scene
// of processing/irm/testing_scene.h seen by two cameras under two suns, and the truth (the
// source camera's render under the target light).
#pragma once

#include <memory>
#include <string>

#include "processing/irm/relight.h"
#include "processing/irm/testing_scene.h"
#include "processing/metrics.h"

namespace relume::app::bench {

struct IrmScene {
  // `render_sky_samples` > 0: the renderer's sky is occluded by the scene (as outdoors).
  IrmScene(int width, int height, const irm::testing::Light& source_light, const irm::testing::Light& target_light,
           int render_sky_samples, bool with_neighbour = true);
  // The outdoor scene (ground, building, taller neighbour); without the neighbour, the
  // building alone on the ground (nothing casts a shadow onto it from the south).
  TriangleMesh mesh;
  std::unique_ptr<RayCaster> caster;
  PinholeCamera source_camera, target_camera;
  irm::testing::Light source_light, target_light;
  RadianceImage source, target, truth;
  cv::Mat truth_source_sun, truth_target_sun;  // per-pixel sun fractions of the source camera
  irm::View SourceView() const { return {&source, source_camera, source_light.sun_dir, {}}; }
  irm::View TargetView() const { return {&target, target_camera, target_light.sun_dir, {}}; }
};

// The relit pixels against the truth, per sun region, by the same measure as the irm
// pipeline's comparison with the truth (processing/metrics.h: per-sample relative RMS after the
// fitted scale, regions at sun fractions 0.01 / 0.99).
metrics::SunRegionErrors CompareRelit(const IrmScene& s, const irm::RelightResult& result);
std::string Describe(const metrics::SunRegionErrors& e);

}  // namespace relume::app::bench
