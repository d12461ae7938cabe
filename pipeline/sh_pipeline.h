// `relume process SESSION --pipeline sh`: SH lighting estimation and relighting of a recorded
// RGB-D stream (Ogura & Saito 2015; Ogura et al.; the library in processing/, see
// docs/processing-sh.md).
//
// Per RGB-D pair (depth + colour of one device, paired by time), three cached stages:
//   radiance-<id>  the colour frame as linear radiance
//   geometry-<id>  bilateral + temporal depth filter, normals (or the previous frame's normals
//                  when the depth did not change beyond tolerance), object mask
//   fit-<id>       SH light (known albedo from the rig's world, or unknown albedo by k-means)
// and, for every source frame, relight-<id>: I_dst = I_src E_dst(n) / E_src(n), composited over
// the source. Frames and lights are in the colour camera's frame (x right, y down, z forward).
//
// SH light JSON (written per frame, read by --target-light FILE.json):
//   {"convention": "...", "frame": "camera", "order": 2,
//    "coefficients": [[R, G, B] x 9]}   rows k = l (l + 1) + m, processing/sh.h's basis.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "pipeline/pipeline.h"
#include "processing/sh.h"

namespace relume::pipeline {

nlohmann::json ShLightToJson(const processing::ShRgb& light, int order);
// Throws InvalidArgumentError naming `what` when the JSON is not an SH light.
processing::ShRgb ShLightFromJson(const nlohmann::json& json, const std::string& what);

// The pipeline as `relume process` lists it: name, description, run function and knobs.
PipelineEntry ShPipelineEntry();

}  // namespace relume::pipeline
