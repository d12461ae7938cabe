#include "apps/relume/bench_command.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <opencv2/photo.hpp>
#include <sstream>

#include "calibration/hdr_merge.h"
#include "calibration/response.h"
#include "calibration/testing/synthetic_bracket.h"
#include "core/error.h"
#include "core/site.h"
#include "core/sun/sun_position.h"
#include "core/sun/sun_track.h"

namespace relume::app {
namespace {

namespace fs = std::filesystem;
namespace ct = calibration::testing;

struct Row {
  std::string stage;
  std::string method;
  std::string knobs;
  double seconds = 0.0;     // per run (best of the repeats)
  double throughput = 0.0;  // items per second (MP/s for images, positions/s for the sun)
  std::string throughput_unit;
  double error = 0.0;
  std::string error_metric;
};

template <typename F>
double BestSeconds(int repeats, F&& f) {
  double best = 1e300;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return best;
}

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
                      "mean relative radiance error"});

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
                      ct::CompareRadiance(cv_rgb, radiance, mask).mean_relative, "mean relative radiance error"});

      // The merge alone, both with the true response.
      const calibration::CameraResponse truth = ct::TrueInverseResponse(response);
      const double merge_only = BestSeconds(repeats, [&] { merged = calibration::MergeHdr(frames, times, truth); });
      rows.push_back({"hdr-merge", "relume MergeHdr (true response)", knobs, merge_only, mp / merge_only, "MP/s",
                      ct::CompareRadiance(merged.radiance.pixels, radiance, mask).mean_relative,
                      "mean relative radiance error"});
      cv::Mat truth_cv(256, 1, CV_32FC3);
      for (int z = 0; z < 256; ++z) {
        for (int c = 0; c < 3; ++c) truth_cv.at<cv::Vec3f>(z)[2 - c] = static_cast<float>(truth.inverse[c][z]);
      }
      const double cv_merge_only =
          BestSeconds(repeats, [&] { cv::createMergeDebevec()->process(mats, cv_merged, times_f, truth_cv); });
      cv::cvtColor(cv_merged, cv_rgb, cv::COLOR_BGR2RGB);
      rows.push_back({"hdr-merge", "OpenCV MergeDebevec (true response)", knobs, cv_merge_only, mp / cv_merge_only,
                      "MP/s", ct::CompareRadiance(cv_rgb, radiance, mask).mean_relative,
                      "mean relative radiance error"});
    }
  }
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
                  "positions/s", 0.0, "max angle from per-call SPA (deg)"});
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
                  count / track, "positions/s", worst * 180.0 / M_PI, "max angle from per-call SPA (deg)"});
}

std::string Format(double v) {
  std::ostringstream s;
  s << std::setprecision(4) << v;
  return s.str();
}

// Run time (log x) against error (log y), one colour per method.
std::string PlotSvg(const std::string& stage, const std::vector<Row>& rows) {
  std::vector<const Row*> mine;
  for (const Row& r : rows) {
    if (r.stage == stage) mine.push_back(&r);
  }
  const int w = 720, h = 420, left = 70, right = 260, top = 20, bottom = 50;
  double t0 = 1e300, t1 = 0, e0 = 1e300, e1 = 0;
  for (const Row* r : mine) {
    t0 = std::min(t0, r->seconds);
    t1 = std::max(t1, r->seconds);
    const double e = std::max(r->error, 1e-12);
    e0 = std::min(e0, e);
    e1 = std::max(e1, e);
  }
  const double lt0 = std::floor(std::log10(t0)), lt1 = std::ceil(std::log10(t1)) + (t0 == t1 ? 1 : 0);
  const double le0 = std::floor(std::log10(e0)), le1 = std::ceil(std::log10(e1)) + (e0 == e1 ? 1 : 0);
  auto x = [&](double t) { return left + (std::log10(t) - lt0) / (lt1 - lt0) * (w - left - right); };
  auto y = [&](double e) { return top + (le1 - std::log10(std::max(e, 1e-12))) / (le1 - le0) * (h - top - bottom); };
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h << "\">\n"
      << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << w - left - right << "\" height=\""
      << h - top - bottom << "\" fill=\"#fafafa\" stroke=\"#ccc\"/>\n";
  for (double d = lt0; d <= lt1; d += 1) {
    svg << "<text x=\"" << x(std::pow(10, d)) << "\" y=\"" << h - bottom + 16
        << "\" font-size=\"11\" text-anchor=\"middle\">1e" << d << " s</text>\n";
  }
  for (double d = le0; d <= le1; d += 1) {
    svg << "<text x=\"" << left - 6 << "\" y=\"" << y(std::pow(10, d)) + 4
        << "\" font-size=\"11\" text-anchor=\"end\">1e" << d << "</text>\n";
  }
  svg << "<text x=\"" << (left + w - right) / 2 << "\" y=\"" << h - 10
      << "\" font-size=\"12\" text-anchor=\"middle\">run time per call (s)</text>\n";
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
  std::vector<std::string> methods;
  for (const Row* r : mine) {
    if (std::find(methods.begin(), methods.end(), r->method) == methods.end()) methods.push_back(r->method);
  }
  for (const Row* r : mine) {
    const auto index = std::find(methods.begin(), methods.end(), r->method) - methods.begin();
    svg << "<circle cx=\"" << x(r->seconds) << "\" cy=\"" << y(r->error) << "\" r=\"4\" fill=\"" << colours[index % 4]
        << "\"><title>" << r->method << ", " << r->knobs << ": " << Format(r->seconds) << " s, " << Format(r->error)
        << "</title></circle>\n";
  }
  for (std::size_t i = 0; i < methods.size(); ++i) {
    svg << "<circle cx=\"" << w - right + 14 << "\" cy=\"" << top + 10 + 16 * i << "\" r=\"4\" fill=\""
        << colours[i % 4] << "\"/><text x=\"" << w - right + 22 << "\" y=\"" << top + 14 + 16 * i
        << "\" font-size=\"11\">" << methods[i] << "</text>\n";
  }
  svg << "<text x=\"" << w - right + 8 << "\" y=\"" << h - bottom
      << "\" font-size=\"11\">y: " << (mine.empty() ? "" : mine.front()->error_metric) << "</text>\n</svg>\n";
  return svg.str();
}

struct BenchArgs {
  std::string stage = "all";
  bool quick = false;
  std::string out = "bench";
};

void Run(const BenchArgs& args) {
  if (args.stage != "all" && args.stage != "hdr" && args.stage != "sun") {
    throw InvalidArgumentError("--stage " + args.stage + ": the stages with a benchmark are hdr and sun (or all)");
  }
  std::vector<Row> rows;
  if (args.stage == "all" || args.stage == "hdr") BenchHdr(args.quick, rows);
  if (args.stage == "all" || args.stage == "sun") BenchSun(args.quick, rows);
  fs::create_directories(args.out);
  std::ofstream csv(fs::path(args.out) / "bench.csv");
  std::ostringstream md;
  csv << "stage,method,knobs,seconds,throughput,throughput_unit,error,error_metric\n";
  md << "| stage | method | knobs | time per call (s) | throughput | error |\n|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    csv << r.stage << ",\"" << r.method << "\",\"" << r.knobs << "\"," << r.seconds << "," << r.throughput << ","
        << r.throughput_unit << "," << r.error << ",\"" << r.error_metric << "\"\n";
    md << "| " << r.stage << " | " << r.method << " | " << r.knobs << " | " << Format(r.seconds) << " | "
       << Format(r.throughput) << " " << r.throughput_unit << " | " << Format(r.error) << " (" << r.error_metric
       << ") |\n";
  }
  std::vector<std::string> stages;
  for (const Row& r : rows) {
    if (std::find(stages.begin(), stages.end(), r.stage) == stages.end()) stages.push_back(r.stage);
  }
  for (const std::string& stage : stages)
    std::ofstream(fs::path(args.out) / ("bench-" + stage + ".svg")) << PlotSvg(stage, rows);
  std::ofstream(fs::path(args.out) / "bench.md") << md.str();
  std::cout << md.str() << "wrote " << args.out << "/bench.csv, bench.md and one SVG plot per stage\n";
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand("bench", "Run time against error, with the independent peers beside relume");
  cmd->add_option("--stage", args->stage, "hdr, sun or all")->capture_default_str();
  cmd->add_flag("--quick", args->quick, "Small inputs: a minute or two, for CI");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  cmd->callback([args]() { Run(*args); });
}

}  // namespace relume::app
