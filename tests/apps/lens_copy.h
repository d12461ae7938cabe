// Test support for the lens tests of the pipelines (irm_pipeline_test.cc, sh_pipeline_test.cc):
// a session copied with its frames through a lens starts with its scene model, whose one camera
// gets the distortion the test wants the pipeline to believe.
#pragma once

#include <vector>

#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"

namespace relume::testing {

// Adds `in`'s latest scene model to `out`, its one camera's distortion set to `distortion`;
// returns that camera's intrinsics. InvalidArgumentError when `in` has no model or not one camera.
inline PinholeIntrinsics CopySceneModelWithDistortion(const capture::SessionReader& in, capture::SessionWriter& out,
                                                      const std::vector<double>& distortion) {
  const std::vector<capture::CalibrationRecord> rows = in.Calibrations();
  const capture::CalibrationRecord* row = capture::LatestSceneModelRow(rows);
  if (row == nullptr) throw InvalidArgumentError("the session to copy has no scene model");
  SceneModel model = capture::SceneModelFromJson(row->json, "scene model");
  if (model.cameras.size() != 1) throw InvalidArgumentError("the session to copy has not one camera");
  model.cameras.front().distortion = distortion;
  capture::CalibrationRecord scene = *row;
  scene.json = capture::SceneModelToJson(model);
  out.AddCalibration(scene);
  return model.cameras.front().camera.intrinsics;
}

}  // namespace relume::testing
