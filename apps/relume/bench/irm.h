// The IRM stage's scene, shared by the `irm` and `planner` benches: the analytic outdoor scene
// of processing/irm/testing_scene.h seen by two cameras under two suns, and the truth (the
// source camera's render under the target light).
#pragma once

#include <memory>
#include <string>

#include "processing/irm/relight.h"
#include "processing/irm/testing_scene.h"

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

// Relative RMS (per channel |relit - truth| / truth) over the relit pixels, and per region by
// the true sun fractions in both lights: lit in both, shadow (umbra in either, pure in both),
// penumbra (partial in either).
struct IrmErrors {
  double all = 0.0, lit = 0.0, shadow = 0.0, penumbra = 0.0;
  int n_all = 0, n_lit = 0, n_shadow = 0, n_penumbra = 0;
  std::string Describe() const;
};
IrmErrors CompareRelit(const IrmScene& s, const irm::RelightResult& result);

}  // namespace relume::app::bench
