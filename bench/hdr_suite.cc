// The HDR random-response suite (issue 20): "HDR radiance, 5 frames, random monotone
// responses".
//
// Scene i (seed options.SeedOf(i), drawn with SceneRandom): a synthetic radiance of
// patches (calibration/testing MakeHdrRadiance) with a dynamic range log-uniform in
// [1e3, 3e4]; 5 frames with a constant EV step uniform in [1.5, 2.5] around a middle exposure
// that puts the scene's log-centre at X = 0.18 times 2^U(-1, 1); shot noise log-uniform in
// [2e-5, 3e-4] (full well ~3k-50k electrons) and read noise log-uniform in [1e-4, 1e-3] of full
// scale; a random monotone response per channel (calibration/testing RandomResponse).
//
// Method: relume's `calibrate response` + `hdr merge` with their defaults
// (calibration::RecoverResponse, then MergeHdr). Peer: OpenCV's CalibrateDebevec +
// MergeDebevec with theirs. Floor (both): MergeHdr given the true inverse response
// (TrueInverseResponse), i.e. what the merge alone costs on this bracket and noise.
// Error: CompareRadiance's mean relative radiance error over the pixels some frame exposes well
// (every channel's noise-free code in [10, 245]), after one median scale per channel.
#include <chrono>
#include <cmath>
#include <iomanip>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <sstream>

#include "bench/suites.h"
#include "calibration/hdr_merge.h"
#include "calibration/response.h"
#include "calibration/testing/synthetic_bracket.h"

namespace relume::bench {
namespace {

namespace ct = calibration::testing;

constexpr const char* kMetric = "mean relative radiance error (well-exposed pixels, one scale per channel)";
constexpr const char* kFloor = "the true response (MergeHdr)";

// What one scene drew.
struct HdrScene {
  cv::Mat radiance;
  std::vector<double> times;
  ct::SyntheticResponse response;
  ct::NoiseOptions noise;
  double dynamic_range = 0.0;
  double ev_step = 0.0;
  double middle_offset_ev = 0.0;
  std::string description;
};

double LogUniform(SceneRandom& rng, double lo, double hi) {
  return std::exp(rng.Uniform(std::log(lo), std::log(hi)));
}

HdrScene DrawScene(std::uint64_t seed, bool quick) {
  SceneRandom rng(seed);
  HdrScene s;
  ct::SceneOptions scene;
  scene.width = quick ? 240 : 640;
  scene.height = quick ? 160 : 427;
  s.dynamic_range = LogUniform(rng, 1e3, 3e4);
  scene.dynamic_range = s.dynamic_range;
  scene.seed = rng.Next();
  s.radiance = ct::MakeHdrRadiance(scene);
  s.ev_step = rng.Uniform(1.5, 2.5);
  // MakeHdrRadiance's values lie in about [0.55 * 0.5 / range, 1): put their log-centre at
  // mid-grey in the middle frame, give or take one stop.
  const double centre = std::sqrt(0.55 * 0.5 / s.dynamic_range);
  s.middle_offset_ev = rng.Uniform(-1.0, 1.0);
  s.times = ct::BracketExposures(5, s.ev_step, 0.18 / centre * std::exp2(s.middle_offset_ev));
  s.noise.shot_noise = LogUniform(rng, 2e-5, 3e-4);
  s.noise.read_noise = LogUniform(rng, 1e-4, 1e-3);
  s.noise.seed = rng.Next();
  s.response = ct::RandomResponse(rng.Next());
  std::ostringstream d;
  d << std::setprecision(3) << "range " << s.dynamic_range << ":1, 5 frames " << s.ev_step << " EV apart, middle "
    << std::showpos << s.middle_offset_ev << std::noshowpos << " EV, shot " << s.noise.shot_noise << ", read "
    << s.noise.read_noise << ", response " << ct::DescribeResponse(s.response);
  s.description = d.str();
  return s;
}

// RMS of ln(recovered / true) over codes [10, 245], after removing the mean (the scale is
// free), worst channel: how far the recovered curve is from the truth.
double ResponseLogRms(const std::vector<std::vector<double>>& recovered, const calibration::CameraResponse& truth) {
  double worst = 0.0;
  for (std::size_t c = 0; c < recovered.size(); ++c) {
    std::vector<double> d;
    for (int z = 10; z <= 245; ++z) {
      if (recovered[c][z] > 0.0 && truth.inverse[c][z] > 0.0)
        d.push_back(std::log(recovered[c][z] / truth.inverse[c][z]));
    }
    if (d.empty()) return std::numeric_limits<double>::infinity();
    double mean = 0.0, sq = 0.0;
    for (const double v : d) mean += v / static_cast<double>(d.size());
    for (const double v : d) sq += (v - mean) * (v - mean);
    worst = std::max(worst, std::sqrt(sq / static_cast<double>(d.size())));
  }
  return worst;
}

std::string Percent(double v) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << 100.0 * v << " %";
  return s.str();
}

}  // namespace

std::vector<SuiteResult> RunHdrSuite(const SuiteOptions& options) {
  SuiteResult ours, opencv;
  ours.suite = "hdr-random-response";
  ours.metric = kMetric;
  ours.method = "relume calibrate response (Debevec-Malik, log-code smoothness, 300 samples) + hdr merge";
  ours.floor = kFloor;
  ours.goal_median = 0.01;
  ours.goal_p90 = 0.015;
  opencv.suite = "hdr-opencv-debevec";
  opencv.metric = kMetric;
  opencv.method = "OpenCV CalibrateDebevec + MergeDebevec (defaults)";
  opencv.floor = kFloor;
  for (int i = 0; i < options.SceneCount(); ++i) {
    const std::uint64_t seed = options.SeedOf(i);
    const HdrScene scene = DrawScene(seed, options.quick);
    const std::vector<CameraImage> frames = ct::RenderBracket(scene.radiance, scene.times, scene.response, scene.noise);
    const cv::Mat mask = ct::WellExposedMask(scene.radiance, scene.times, scene.response);
    const double mask_share = static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total());
    const calibration::CameraResponse truth = ct::TrueInverseResponse(scene.response);
    auto error = [&](const cv::Mat& estimate) {
      return ct::CompareRadiance(estimate, scene.radiance, mask).mean_relative;
    };
    const double floor = error(calibration::MergeHdr(frames, scene.times, truth).radiance.pixels);
    // The floor without sensor noise: what 8-bit quantisation and clipping alone cost.
    ct::NoiseOptions no_noise;
    const double quantisation_floor =
        error(calibration::MergeHdr(ct::RenderBracket(scene.radiance, scene.times, scene.response, no_noise),
                                    scene.times, truth)
                  .radiance.pixels);

    SceneResult mine;
    mine.seed = seed;
    mine.floor = floor;
    mine.description = scene.description;
    const auto start = std::chrono::steady_clock::now();
    const calibration::ResponseResult recovered = calibration::RecoverResponse(frames, scene.times);
    if (recovered.summary.usable) {
      const calibration::HdrMergeResult merged = calibration::MergeHdr(frames, scene.times, recovered.response);
      mine.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      mine.method = error(merged.radiance.pixels);
      std::ostringstream n;
      n << "response log-RMS " << Percent(ResponseLogRms(recovered.response.inverse, truth)) << ", prior disagreement "
        << Percent(recovered.summary.prior_disagreement.value_or(0.0))
        << (recovered.summary.low_confidence ? " (low confidence)" : "") << ", samples "
        << recovered.summary.samples_used << ", well-exposed " << Percent(mask_share)
        << " of pixels, floor without noise " << Percent(quantisation_floor);
      mine.notes = n.str();
    } else {
      mine.notes = "failed: the response was not recovered: " + recovered.summary.reason;
    }
    ours.scenes.push_back(mine);

    // OpenCV, on BGR copies of the same frames.
    SceneResult theirs;
    theirs.seed = seed;
    theirs.floor = floor;
    theirs.description = scene.description;
    std::vector<cv::Mat> bgr(frames.size());
    for (std::size_t f = 0; f < frames.size(); ++f) cv::cvtColor(frames[f].pixels, bgr[f], cv::COLOR_RGB2BGR);
    const std::vector<float> times_f(scene.times.begin(), scene.times.end());
    cv::Mat cv_response, cv_merged, cv_rgb;
    const auto cv_start = std::chrono::steady_clock::now();
    cv::createCalibrateDebevec()->process(bgr, cv_response, times_f);
    cv::createMergeDebevec()->process(bgr, cv_merged, times_f, cv_response);
    theirs.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - cv_start).count();
    cv::cvtColor(cv_merged, cv_rgb, cv::COLOR_BGR2RGB);
    theirs.method = error(cv_rgb);
    std::vector<std::vector<double>> cv_curve(3, std::vector<double>(256));
    for (int z = 0; z < 256; ++z) {
      for (int c = 0; c < 3; ++c) cv_curve[c][z] = cv_response.at<cv::Vec3f>(z)[2 - c];
    }
    // OpenCV's merge alone, given the true response: how much of its error is the merge's.
    cv::Mat truth_bgr(256, 1, CV_32FC3), cv_truth_merged;
    for (int z = 0; z < 256; ++z) {
      for (int c = 0; c < 3; ++c) truth_bgr.at<cv::Vec3f>(z)[2 - c] = static_cast<float>(truth.inverse[c][z]);
    }
    cv::createMergeDebevec()->process(bgr, cv_truth_merged, times_f, truth_bgr);
    cv::cvtColor(cv_truth_merged, cv_truth_merged, cv::COLOR_BGR2RGB);
    theirs.notes = "response log-RMS " + Percent(ResponseLogRms(cv_curve, truth)) +
                   ", MergeDebevec given the true response " + Percent(error(cv_truth_merged));
    opencv.scenes.push_back(theirs);
  }
  return {ours, opencv};
}

}  // namespace relume::bench
