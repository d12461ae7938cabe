#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <sstream>

#include "apps/relume/bench/bench.h"
#include "apps/relume/calibrate_command.h"
#include "apps/relume/hdr_command.h"
#include "calibration/hdr_merge.h"
#include "calibration/image_file.h"
#include "calibration/response.h"
#include "calibration/testing/synthetic_bracket.h"
#include "core/error.h"
#include "core/site.h"
#include "core/sun/sun_position.h"
#include "core/sun/sun_track.h"

namespace relume::app::bench {

namespace ct = calibration::testing;

// HDR: response recovery + merge, relume's against OpenCV's, and the merge alone with the true
// response; error = mean relative radiance error against the synthetic truth where any frame
// exposes well (after one scale per channel).
void BenchHdr(bool quick, std::vector<Row>& rows) {
  const int width = quick ? 320 : 1024, height = quick ? 240 : 768;
  const int repeats = quick ? 1 : 3;
  for (const int count : quick ? std::vector<int>{3, 5} : std::vector<int>{3, 5, 7, 9}) {
    for (const ct::ResponseShape shape : {ct::ResponseShape::kGamma, ct::ResponseShape::kSCurve}) {
      ct::SceneOptions scene;
      scene.width = width;
      scene.height = height;
      scene.dynamic_range = 1e4;
      const cv::Mat radiance = ct::MakeHdrRadiance(scene);
      const std::vector<double> times = ct::BracketExposures(count, 2.0, 18.0);  // 2 EV apart, around the scene
      const ct::SyntheticResponse response{shape};
      ct::NoiseOptions noise;
      noise.shot_noise = 1e-4;
      noise.read_noise = 5e-4;
      const std::vector<CameraImage> frames = ct::RenderBracket(radiance, times, response, noise);
      const cv::Mat mask = ct::WellExposedMask(radiance, times, response);
      const double mp = static_cast<double>(width) * height * count / 1e6;
      const std::string knobs = std::to_string(count) + " frames 2 EV apart, " + ct::ToString(shape) + ", noisy";

      calibration::ResponseResult recovered;
      calibration::HdrMergeResult merged;
      const double ours = BestSeconds(repeats, [&] {
        recovered = calibration::RecoverResponse(frames, times);
        if (!recovered.summary.usable) {
          throw InvalidArgumentError("bench: the response was not recovered (" + knobs +
                                     "): " + recovered.summary.reason);
        }
        merged = calibration::MergeHdr(frames, times, recovered.response);
      });
      rows.push_back({"hdr", "relume Debevec-Malik + merge", knobs, ours, mp / ours, "MP/s",
                      ct::CompareRadiance(merged.radiance.pixels, radiance, mask).mean_relative,
                      "mean relative radiance error", ""});

      std::vector<cv::Mat> mats;
      for (const CameraImage& f : frames) {
        cv::Mat bgr;
        cv::cvtColor(f.pixels, bgr, cv::COLOR_RGB2BGR);
        mats.push_back(bgr);
      }
      std::vector<float> times_f(times.begin(), times.end());
      cv::Mat cv_response, cv_merged;
      const double theirs = BestSeconds(repeats, [&] {
        cv::createCalibrateDebevec()->process(mats, cv_response, times_f);
        cv::createMergeDebevec()->process(mats, cv_merged, times_f, cv_response);
      });
      cv::Mat cv_rgb;
      cv::cvtColor(cv_merged, cv_rgb, cv::COLOR_BGR2RGB);
      rows.push_back({"hdr", "OpenCV CalibrateDebevec + MergeDebevec", knobs, theirs, mp / theirs, "MP/s",
                      ct::CompareRadiance(cv_rgb, radiance, mask).mean_relative, "mean relative radiance error", ""});

      // The merge alone, both with the true response.
      const calibration::CameraResponse truth = ct::TrueInverseResponse(response);
      const double merge_only = BestSeconds(repeats, [&] { merged = calibration::MergeHdr(frames, times, truth); });
      rows.push_back({"hdr-merge", "relume MergeHdr (true response)", knobs, merge_only, mp / merge_only, "MP/s",
                      ct::CompareRadiance(merged.radiance.pixels, radiance, mask).mean_relative,
                      "mean relative radiance error", ""});
      cv::Mat truth_cv(256, 1, CV_32FC3);
      for (int z = 0; z < 256; ++z) {
        for (int c = 0; c < 3; ++c) truth_cv.at<cv::Vec3f>(z)[2 - c] = static_cast<float>(truth.inverse[c][z]);
      }
      const double cv_merge_only =
          BestSeconds(repeats, [&] { cv::createMergeDebevec()->process(mats, cv_merged, times_f, truth_cv); });
      cv::cvtColor(cv_merged, cv_rgb, cv::COLOR_BGR2RGB);
      rows.push_back({"hdr-merge", "OpenCV MergeDebevec (true response)", knobs, cv_merge_only, mp / cv_merge_only,
                      "MP/s", ct::CompareRadiance(cv_rgb, radiance, mask).mean_relative, "mean relative radiance error",
                      ""});
    }
  }
}

// HDR end to end from files, as a user runs it (issue 20's goal: relume >= 3x OpenCV with
// reading and writing included): a 1200 x 800 five-frame JPEG bracket on disk; relume's
// `calibrate response` + `hdr merge` (RunCalibrateResponse, RunHdrMerge: every file they read
// and write, the response plot and the merge's report images included) against OpenCV's
// imread + CalibrateDebevec + MergeDebevec + imwrite of the EXR, in the same run.
void BenchHdrFiles(bool quick, std::vector<Row>& rows) {
  const int width = quick ? 600 : 1200, height = quick ? 400 : 800;
  const int repeats = quick ? 1 : 3;
  ct::SceneOptions scene;
  scene.width = width;
  scene.height = height;
  scene.dynamic_range = 1e4;
  const cv::Mat radiance = ct::MakeHdrRadiance(scene);
  const std::vector<double> times = ct::BracketExposures(5, 2.0, 18.0);
  const ct::SyntheticResponse response{ct::ResponseShape::kGamma};
  ct::NoiseOptions noise;
  noise.shot_noise = 1e-4;
  noise.read_noise = 5e-4;
  const std::vector<CameraImage> frames = ct::RenderBracket(radiance, times, response, noise);
  const cv::Mat mask = ct::WellExposedMask(radiance, times, response);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("relume-bench-hdr-files-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::vector<std::string> files;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    cv::Mat bgr;
    cv::cvtColor(frames[i].pixels, bgr, cv::COLOR_RGB2BGR);
    files.push_back((dir / ("frame" + std::to_string(i) + ".jpg")).string());
    if (!cv::imwrite(files.back(), bgr, {cv::IMWRITE_JPEG_QUALITY, 95}))
      throw IoError(files.back(), "cannot be written");
  }
  const double mp = static_cast<double>(width) * height * 5 / 1e6;
  const std::string knobs = std::to_string(width) + "x" + std::to_string(height) + ", 5 JPEG frames 2 EV apart, gamma";
  std::ostringstream discard;
  const double ours = BestSeconds(repeats, [&] {
    CalibrateResponseArgs calibrate;
    calibrate.files = files;
    calibrate.exposure.exposures_s = times;
    calibrate.out = (dir / "response.json").string();
    RunCalibrateResponse(calibrate, discard);
    HdrMergeArgs merge;
    merge.files = files;
    merge.exposure.exposures_s = times;
    merge.profile = calibrate.out;
    merge.out = (dir / "relume.exr").string();
    RunHdrMerge(merge, discard);
  });
  const cv::Mat ours_image = calibration::LoadRadianceExr((dir / "relume.exr").string()).pixels;
  rows.push_back({"hdr-files", "relume calibrate response + hdr merge (files in and out)", knobs, ours, mp / ours,
                  "MP/s", ct::CompareRadiance(ours_image, radiance, mask).mean_relative, "mean relative radiance error",
                  "writes response.json + plot, merged.exr, 3 report PNGs and a JSON report"});
  std::vector<float> times_f(times.begin(), times.end());
  const double theirs = BestSeconds(repeats, [&] {
    std::vector<cv::Mat> mats;
    for (const std::string& f : files) mats.push_back(cv::imread(f, cv::IMREAD_COLOR));
    cv::Mat cv_response, cv_merged;
    cv::createCalibrateDebevec()->process(mats, cv_response, times_f);
    cv::createMergeDebevec()->process(mats, cv_merged, times_f, cv_response);
    // The EXR as relume's `hdr merge` writes it by default (uncompressed): the same bytes to disk.
    if (!cv::imwrite((dir / "opencv.exr").string(), cv_merged,
                     {cv::IMWRITE_EXR_COMPRESSION, cv::IMWRITE_EXR_COMPRESSION_NO})) {
      throw IoError((dir / "opencv.exr").string(), "cannot be written");
    }
  });
  cv::Mat theirs_image;
  cv::cvtColor(cv::imread((dir / "opencv.exr").string(), cv::IMREAD_UNCHANGED), theirs_image, cv::COLOR_BGR2RGB);
  rows.push_back({"hdr-files", "OpenCV imread + CalibrateDebevec + MergeDebevec + imwrite", knobs, theirs, mp / theirs,
                  "MP/s", ct::CompareRadiance(theirs_image, radiance, mask).mean_relative,
                  "mean relative radiance error", "relume / OpenCV time " + Format(ours / theirs)});
  if (std::getenv("RELUME_BENCH_KEEP") == nullptr) std::filesystem::remove_all(dir);
}

// The sun over a year at one site: the time-series path against per-call SPA (the reference
// here; SPA itself is checked against ERFA in core's tests, docs/sun.md).
void BenchSun(bool quick, std::vector<Row>& rows) {
  const Site site = Site::FromDegrees(37.97153, 23.72644, 190.0);
  const std::size_t count = quick ? 20000 : 200000;
  const UtcTime start = ParseIso8601("2026-01-01T00:00:00Z").utc;
  const Nanoseconds step =
      std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(365.25 * 86400 / count));
  std::vector<SunPosition> reference(count);
  const double spa = BestSeconds(1, [&] {
    for (std::size_t i = 0; i < count; ++i)
      reference[i] = ComputeSunPosition(site, start + step * static_cast<long>(i));
  });
  rows.push_back({"sun", "SPA per call", std::to_string(count) + " instants over a year", spa, count / spa,
                  "positions/s", 0.0, "max angle from per-call SPA (deg)", ""});
  std::vector<SunPosition> series;
  const double track = BestSeconds(quick ? 1 : 3, [&] {
    SunTrack sun(site);
    series = sun.Series(start, step, count);
  });
  double worst = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    const double de = std::fabs(series[i].elevation_rad - reference[i].elevation_rad);
    double da = std::fabs(series[i].azimuth_rad - reference[i].azimuth_rad);
    da = std::min(da, 2 * M_PI - da) * std::cos(reference[i].elevation_rad);
    worst = std::max({worst, de, da});
  }
  rows.push_back({"sun", "SunTrack (time series)", std::to_string(count) + " instants over a year", track,
                  count / track, "positions/s", worst * 180.0 / M_PI, "max angle from per-call SPA (deg)", ""});
}

}  // namespace relume::app::bench
