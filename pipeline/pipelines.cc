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

void RunRadiancePipeline(PipelineRun& run) {
  const auto brackets = StillBrackets(run.session(), run.request().source);
  if (brackets.empty()) {
    run.Decide("radiance", "skip", "the session has no still-camera frames");
    return;
  }
  run.Decide("radiance", "plan", std::to_string(brackets.size()) + " bracket(s) of still frames to linearise");
  if (run.request().explain) return;
  nlohmann::json& per_bracket = run.metrics()["brackets"];
  const bool truth = run.ReadKnobs<RadiancePipelineKnobs>().compare_truth;
  double worst = 0.0;
  int done = 0;
  for (const auto& bracket : brackets) {
    // Images are read only when the truth stage runs: a rerun reads none.
    const BracketRadiance r = LinearRadiance(run, bracket, /*load=*/false);
    nlohmann::json m = {{"device", r.device_id},
                        {"frames", r.frame_ids},
                        {"utc", FormatIso8601(r.utc)},
                        {"sun_elevation_deg", r.sun_elevation_deg},
                        {"exr", std::filesystem::relative(r.exr, run.out_dir()).string()}};
    const std::optional<PinholeCamera> truth_camera =
        run.truth() != nullptr ? run.truth()->DeviceCamera(r.device_id) : std::nullopt;
    if (truth && truth_camera) {
      // A stage of its own, so a rerun with unchanged radiance does not render the world again.
      StageKey key;
      key.Add("stage", "radiance-truth-v1").AddKey("radiance", r.key);
      key.Add("truth", run.truth()->Key()).Add("device", r.device_id).Add("utc", FormatIso8601(r.utc));
      const StageCache::Result stage = run.RunStage("radiance-truth", key, [&](const std::filesystem::path& dir) {
        const GroundTruth gt = run.truth()->Render(*truth_camera, r.utc);
        const RadianceImage radiance = calibration::LoadRadianceExr(r.exr.string());
        const cv::Mat status = cv::imread((r.exr.parent_path() / "status.png").string(), cv::IMREAD_UNCHANGED);
        const TruthComparison cmp = CompareWithTruth(radiance, status, gt.radiance);
        std::ofstream(dir / "truth.json")
            << nlohmann::json{{"relative_rms", cmp.relative_rms}, {"pixels", cmp.pixels}, {"scale", cmp.scale}};
      });
      const nlohmann::json cmp = nlohmann::json::parse(std::ifstream(stage.dir / "truth.json"));
      m["truth_relative_rms"] = cmp["relative_rms"];
      m["truth_pixels"] = cmp["pixels"];
      m["truth_scale"] = cmp["scale"];
      worst = std::max(worst, cmp["relative_rms"].get<double>());
    }
    run.AddOutput(
        r.exr, "linear radiance of " + r.device_id + (r.bracket_id ? " bracket " + std::to_string(*r.bracket_id) : ""));
    per_bracket.push_back(m);
    run.Progress("radiance", ++done, static_cast<std::int64_t>(brackets.size()));
  }
  if (worst > 0.0) run.metrics()["truth_relative_rms_max"] = worst;
}

std::string RadianceHeadline(const nlohmann::json& m) {
  if (!m.contains("brackets")) return "";
  std::string text = std::to_string(Field(m, "brackets").size()) + " bracket(s) linearised";
  if (m.contains("truth_relative_rms_max")) {
    text += "; against the truth: worst relative RMS " + PercentText(Field(m, "truth_relative_rms_max"));
  }
  return text;
}

std::vector<Figure> RadianceFigures(const nlohmann::json& m) {
  std::vector<Figure> f;
  if (!m.contains("brackets")) return f;
  for (const nlohmann::json& b : Field(m, "brackets")) {
    const std::string name = b.value("device", "") + " at " + b.value("utc", "");
    AddFigure(f, name + ": relative RMS against the truth", b.value("truth_relative_rms", nlohmann::json()), "%");
    AddFigure(f, name + ": sun elevation", b.value("sun_elevation_deg", nlohmann::json()), "deg", 3);
  }
  return f;
}

}  // namespace

const std::vector<PipelineEntry>& Pipelines() {
  static const std::vector<PipelineEntry> pipelines = {
      {"radiance",
       "linear HDR radiance of every still bracket (merge, response, colour profile)",
       RunRadiancePipeline,
       WithRadianceKnobs(DescribeKnobs<RadiancePipelineKnobs>()),
       RadianceHeadline,
       RadianceFigures,
       {"radiance"}},
      ShPipelineEntry(),
      IrmPipelineEntry(),
      RadiosityPipelineEntry(),
  };
  return pipelines;
}

}  // namespace relume::pipeline
