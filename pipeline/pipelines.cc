// The pipelines of this build, and the `radiance` pipeline (linear radiance of every still
// bracket, checked against the simulated world's truth when the session is simulated).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibration/image_file.h"
#include "calibration/response.h"
#include "pipeline/irm_pipeline.h"
#include "pipeline/pipeline.h"
#include "pipeline/radiance.h"
#include "pipeline/radiosity_pipeline.h"
#include "pipeline/sh_pipeline.h"

namespace relume::pipeline {

namespace {

// Relative RMS error of `estimate` against `truth` after one least-squares scale per image
// (relative radiance has one unknown scale), over pixels every channel of which was well
// exposed (status 0) and where the truth is finite and positive.
struct TruthComparison {
  double scale = 0.0;
  double relative_rms = 0.0;
  int pixels = 0;
};

TruthComparison CompareWithTruth(const RadianceImage& estimate, const cv::Mat& status, const RadianceImage& truth) {
  cv::Mat mask(estimate.height(), estimate.width(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < estimate.height(); ++y) {
    const auto* e = estimate.pixels.ptr<cv::Vec3f>(y);
    const auto* t = truth.pixels.ptr<cv::Vec3f>(y);
    const std::uint8_t* s = status.empty() ? nullptr : status.ptr<std::uint8_t>(y);
    for (int x = 0; x < estimate.width(); ++x) {
      bool ok = s == nullptr || s[x] == 0;
      for (int c = 0; c < 3; ++c) ok = ok && std::isfinite(e[x][c]) && std::isfinite(t[x][c]) && t[x][c] > 1e-6f;
      mask.at<std::uint8_t>(y, x) = ok ? 255 : 0;
    }
  }
  const calibration::ScaleFit fit = calibration::FitScaleFactor(estimate.pixels, truth.pixels, mask);
  return {fit.scale, fit.relative_rms, static_cast<int>(fit.samples)};
}

struct RadiancePipelineKnobs {
  bool compare_truth = true;
  template <typename V>
  void VisitKnobs(V& v) {
    v.Knob("compare_truth", compare_truth, "compare each bracket with the simulated world's truth", {"report"});
  }
};

// The radiance pipeline's summary: per bracket, where its radiance is and how far it is from the
// truth.
struct RadianceBracketSummary {
  std::string device;
  std::vector<std::int64_t> frames;
  std::string utc;
  double sun_elevation_deg = 0.0;
  std::string exr;  // relative to the output folder
  std::optional<double> truth_relative_rms;
  std::optional<int> truth_pixels;
  std::optional<double> truth_scale;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("device", device);
    v.Field("frames", frames);
    v.Field("utc", utc);
    v.Field("sun_elevation_deg", sun_elevation_deg);
    v.Field("exr", exr);
    v.Field("truth_relative_rms", truth_relative_rms);
    v.Field("truth_pixels", truth_pixels);
    v.Field("truth_scale", truth_scale);
  }
};

struct RadianceSummary {
  std::vector<RadianceBracketSummary> brackets;
  std::optional<double> truth_relative_rms_max;  // the worst bracket against the truth
  template <typename V>
  void VisitFields(V& v) {
    v.Field("brackets", brackets);
    v.Field("truth_relative_rms_max", truth_relative_rms_max);
  }
};

// Stage radiance-truth's record (truth.json).
struct RadianceTruthRecord {
  double relative_rms = 0.0;
  int pixels = 0;
  double scale = 0.0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("relative_rms", relative_rms);
    v.Field("pixels", pixels);
    v.Field("scale", scale);
  }
};

RadianceSummary RunRadiancePipeline(PipelineRun& run) {
  RadianceSummary summary;
  const auto brackets = StillBrackets(run.session(), run.request().source);
  if (brackets.empty()) {
    run.Decide("radiance", "skip", "the session has no still-camera frames");
    return summary;
  }
  run.Decide("radiance", "plan", std::to_string(brackets.size()) + " bracket(s) of still frames to linearise");
  if (run.request().explain) return summary;
  const bool truth = run.ReadKnobs<RadiancePipelineKnobs>().compare_truth;
  int done = 0;
  for (const auto& bracket : brackets) {
    // Images are read only when the truth stage runs: a rerun reads none.
    const BracketRadiance r = LinearRadiance(run, bracket, /*load=*/false);
    RadianceBracketSummary& b = summary.brackets.emplace_back();
    b.device = r.device_id;
    b.frames = r.frame_ids;
    b.utc = FormatIso8601(r.utc);
    b.sun_elevation_deg = r.sun_elevation_deg;
    b.exr = std::filesystem::relative(r.exr, run.out_dir()).string();
    const std::optional<PinholeCamera> truth_camera =
        run.truth() != nullptr ? run.truth()->DeviceCamera(r.device_id) : std::nullopt;
    if (truth && truth_camera) {
      // A stage of its own, so a rerun with unchanged radiance does not render the world again.
      StageKey key;
      key.Add("stage", "radiance-truth-v1").AddKey("radiance", r.key);
      key.Add("truth", run.truth()->Key()).Add("device", r.device_id).Add("utc", FormatIso8601(r.utc));
      const StageStore::Result stage = run.RunStage("radiance-truth", key, [&](const std::filesystem::path& dir) {
        const GroundTruth gt = run.truth()->Render(*truth_camera, r.utc);
        const RadianceImage radiance = calibration::LoadRadianceExr(r.exr.string());
        const cv::Mat status = cv::imread((r.exr.parent_path() / "status.png").string(), cv::IMREAD_UNCHANGED);
        const TruthComparison cmp = CompareWithTruth(radiance, status, gt.radiance);
        WriteRecord(dir / "truth.json", RadianceTruthRecord{cmp.relative_rms, cmp.pixels, cmp.scale});
      });
      const auto cmp = ReadRecord<RadianceTruthRecord>(stage.dir / "truth.json");
      b.truth_relative_rms = cmp.relative_rms;
      b.truth_pixels = cmp.pixels;
      b.truth_scale = cmp.scale;
      summary.truth_relative_rms_max = std::max(summary.truth_relative_rms_max.value_or(0.0), cmp.relative_rms);
    }
    run.AddOutput(
        r.exr, "linear radiance of " + r.device_id + (r.bracket_id ? " bracket " + std::to_string(*r.bracket_id) : ""));
    run.Progress("radiance", ++done, static_cast<std::int64_t>(brackets.size()));
  }
  return summary;
}

std::string RadianceHeadline(const RadianceSummary& s) {
  if (s.brackets.empty()) return "";
  std::string text = std::to_string(s.brackets.size()) + " bracket(s) linearised";
  if (s.truth_relative_rms_max) {
    text += "; against the truth: worst relative RMS " + PercentText(s.truth_relative_rms_max);
  }
  return text;
}

std::vector<Figure> RadianceFigures(const RadianceSummary& s) {
  std::vector<Figure> f;
  for (const RadianceBracketSummary& b : s.brackets) {
    const std::string name = b.device + " at " + b.utc;
    AddFigure(f, name + ": relative RMS against the truth", b.truth_relative_rms, "%");
    AddFigure(f, name + ": sun elevation", b.sun_elevation_deg, "deg", 3);
  }
  return f;
}

}  // namespace

const std::vector<PipelineEntry>& Pipelines() {
  static const std::vector<PipelineEntry> pipelines = {
      MakePipelineEntry(
          TypedPipeline<RadianceSummary>{"radiance",
                                         "linear HDR radiance of every still bracket (merge, response, colour profile)",
                                         RunRadiancePipeline,
                                         WithRadianceKnobs(DescribeKnobs<RadiancePipelineKnobs>()),
                                         RadianceHeadline,
                                         RadianceFigures,
                                         {"radiance"}}),
      ShPipelineEntry(),
      IrmPipelineEntry(),
      RadiosityPipelineEntry(),
  };
  return pipelines;
}

}  // namespace relume::pipeline
