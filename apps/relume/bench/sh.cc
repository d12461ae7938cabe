// `sh`: the RGB-D chain (bilateral + temporal depth filter, normals, sample update,
// known-albedo SH fit, relight) on the analytic RGB-D scene of processing/testing, with and
// without Kinect-like depth noise, across SH order, sample count, filter radius and normal
// window. Error: relit relative RMS against the scene rendered under the destination light.
#include "apps/relume/bench/sh.h"

#include <cmath>
#include <numbers>
#include <string>

#include "apps/relume/bench/bench.h"
#include "processing/metrics.h"
#include "processing/relight.h"
#include "processing/sh_pipeline.h"

namespace relume::app::bench {

namespace pt = processing::testing;

ShScene::ShScene(int width, int height) {
  scene.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, 60.0 * std::numbers::pi / 180.0);
  pt::SkySunOptions a, b;
  a.sun_dir_in_map = Eigen::Vector3d(0.6, -0.4, 0.7).normalized();
  b.sun_dir_in_map = Eigen::Vector3d(-0.8, 0.3, 0.35).normalized();
  src_light = processing::ProjectEnvironmentMap(pt::MakeSkySunMap(64, 32, a), pt::CameraFromMap());
  dst_light = processing::ProjectEnvironmentMap(pt::MakeSkySunMap(64, 32, b), pt::CameraFromMap());
  src = pt::RenderScene(scene, src_light);
  dst = pt::RenderScene(scene, dst_light);
}

// As the sh pipeline measures relighting against the truth (processing/metrics.h).
double RelitRelativeRms(const ShScene& s, const processing::RelightResult& r) {
  return metrics::SignalRelativeRms(r.relit.pixels, s.dst.radiance.pixels, r.valid, metrics::Scale::kAbsolute)
      .relative_rms;
}

double IrradianceRelativeRms(const ShScene& s, const processing::ShRgb& light, const cv::Mat& mask) {
  double error = 0.0, total = 0.0;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (!mask.at<unsigned char>(y, x)) continue;
      const cv::Vec3f n = s.src.normal_in_camera.at<cv::Vec3f>(y, x);
      const cv::Vec3f t = s.src.irradiance.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d e = processing::ShIrradiance(light, Eigen::Vector3d(n[0], n[1], n[2]));
      for (int c = 0; c < 3; ++c) {
        error += (e[c] - t[c]) * (e[c] - t[c]);
        total += static_cast<double>(t[c]) * t[c];
      }
    }
  }
  return total > 0.0 ? std::sqrt(error / total) : NAN;
}

ShChainResult RunShChain(const ShScene& s, const processing::ShEstimatorOptions& options,
                         const cv::Mat& previous_depth_m, const cv::Mat& depth_m, const cv::Mat& mask, int repeats) {
  processing::ShLightEstimator estimator(options);
  // The previous frame primes the temporal filter and the sample selector, as in a stream.
  estimator.EstimateKnownAlbedo(s.src.radiance, previous_depth_m, s.scene.intrinsics, mask, s.src.albedo);
  ShChainResult out;
  processing::RelightResult relit;
  out.seconds = BestSeconds(repeats, [&] {
    out.estimate = estimator.EstimateKnownAlbedo(s.src.radiance, depth_m, s.scene.intrinsics, mask, s.src.albedo);
    relit = processing::RelightSh(s.src.radiance, out.estimate.normals.normal_in_camera, mask, out.estimate.light,
                                  s.dst_light);
  });
  out.relit_rms = RelitRelativeRms(s, relit);
  out.irradiance_rms = IrradianceRelativeRms(s, out.estimate.light, mask);
  return out;
}

void BenchSh(bool quick, std::vector<Row>& rows) {
  const int width = quick ? 320 : 640, height = quick ? 240 : 480;
  const ShScene s(width, height);
  const cv::Mat noisy_previous = pt::AddKinectDepthNoise(s.src.depth_m, 41);
  const cv::Mat noisy = pt::AddKinectDepthNoise(s.src.depth_m, 42);
  struct Knobs {
    int order, samples, filter_r, normal_r;
  };
  const std::vector<Knobs> settings =
      quick ? std::vector<Knobs>{{2, 2000, 2, 6}, {1, 2000, 2, 6}, {2, 500, 1, 3}, {2, 8000, 3, 10}}
            : std::vector<Knobs>{{2, 2000, 2, 6}, {1, 2000, 2, 6}, {2, 500, 2, 6},  {2, 8000, 2, 6},
                                 {2, 2000, 1, 6}, {2, 2000, 3, 6}, {2, 2000, 2, 3}, {2, 2000, 2, 10},
                                 {2, 2000, 0, 4}, {1, 500, 1, 3},  {2, 500, 1, 3}};
  const double mp = width * height / 1e6;
  for (const bool noise : {true, false}) {
    for (const Knobs& k : settings) {
      if (!noise && k.filter_r != 2) continue;  // noise-free depth: the filter radius barely matters
      processing::ShEstimatorOptions options;
      options.samples.count = k.samples;
      options.geometry.bilateral.radius_px = k.filter_r;
      options.geometry.normals.window_radius_px = k.normal_r;
      options.fit.fit.max_order = k.order;
      const ShChainResult r = RunShChain(s, options, noise ? noisy_previous : s.src.depth_m,
                                         noise ? noisy : s.src.depth_m, s.src.object_mask, quick ? 2 : 3);
      const std::string knobs = "order " + std::to_string(k.order) + ", " + std::to_string(k.samples) +
                                " samples, filter r " + std::to_string(k.filter_r) + ", normal window " +
                                std::to_string(k.normal_r) + ", " + std::to_string(width) + "x" +
                                std::to_string(height) + (noise ? ", Kinect noise" : ", ideal depth");
      rows.push_back({"sh", "filter + normals + known-albedo SH fit + relight", knobs, r.seconds, mp / r.seconds,
                      "MP/s", r.relit_rms, "relit relative RMS",
                      "irradiance relative RMS " + Format(r.irradiance_rms) + ", order used " +
                          std::to_string(r.estimate.summary.order_used)});
    }
  }
}

}  // namespace relume::app::bench
