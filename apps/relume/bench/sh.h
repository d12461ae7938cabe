// The SH stage's scene and chain, shared by the `sh` and `planner` benches.
#pragma once

#include <opencv2/core/mat.hpp>

#include "processing/relight.h"
#include "processing/sh_pipeline.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::app::bench {

// The analytic RGB-D scene under a source and a destination SH light (the sh_benchmark's).
struct ShScene {
  ShScene(int width, int height);
  processing::testing::SceneOptions scene;
  processing::ShRgb src_light, dst_light;
  processing::testing::SyntheticFrame src, dst;
};

// Relative RMS of a relit image against the destination truth over its valid pixels.
double RelitRelativeRms(const ShScene& s, const processing::RelightResult& r);
// Relative RMS of the light's irradiance at the true normals against the true irradiance.
double IrradianceRelativeRms(const ShScene& s, const processing::ShRgb& light, const cv::Mat& mask);

struct ShChainResult {
  double seconds = 0.0;  // one frame: filter, normals, samples, fit, relight
  double relit_rms = 0.0;
  double irradiance_rms = 0.0;
  processing::ShFrameEstimate estimate;
};
// Runs the chain on `previous_depth_m` (priming the temporal filter), then times it on `depth_m`.
ShChainResult RunShChain(const ShScene& s, const processing::ShEstimatorOptions& options,
                         const cv::Mat& previous_depth_m, const cv::Mat& depth_m, const cv::Mat& mask, int repeats);

}  // namespace relume::app::bench
