// The radiosity stage's scene, shared by the `radiosity` and `planner` benches: the furnished
// test room of processing/radiosity/test_room.h, meshed into patches, with its photographs
// (rendered from a converged fine radiosity solution with the true albedo).
#pragma once

#include <memory>
#include <vector>

#include "processing/radiosity/reflectance.h"
#include "processing/radiosity/test_room.h"

namespace relume::app::bench {

struct RadiosityRoom {
  // `albedo_scale` multiplies every material's albedo (a dark room has little indirect light).
  RadiosityRoom(int lamp_count, double patch_edge_m, double albedo_scale = 1.0);
  radiosity::testing::TestRoom room;
  std::unique_ptr<radiosity::PatchHierarchy> hierarchy;
  std::unique_ptr<RayCaster> caster;
  std::vector<radiosity::RadianceObservation> photos;
};

// Patch-weighted mean over materials of CompareAlbedo's mean |estimate - truth|.
double MeanAlbedoError(const RadiosityRoom& r, const radiosity::ReflectanceResult& result);

}  // namespace relume::app::bench
