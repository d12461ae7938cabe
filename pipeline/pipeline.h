// `relume process SESSION --pipeline NAME`: the frame a processing pipeline runs in.
//
// A pipeline is a function that reads a recorded session, runs its stages through a StageStore
// (by default the StageCache in OUT/stages, so unchanged stages are reused), records what it decided in a PipelineRun
// and returns what it measured as its typed summary (fields.h). The command writes the run's summary (summary.json, the
// typed summary as "metrics") and prints its decisions. Each pipeline lives in its own file under pipeline/ and is
// listed once in Pipelines() (pipelines.cc).
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "capture/session.h"
#include "core/pinhole.h"
#include "core/scene_model.h"
#include "core/truth.h"
#include "pipeline/fields.h"
#include "pipeline/knobs.h"
#include "pipeline/stage_cache.h"

namespace relume::calibration {
class Undistorter;
}  // namespace relume::calibration

namespace relume::pipeline {

struct PipelineRequest {
  std::filesystem::path session_dir;
  std::filesystem::path out_dir;
  std::string pipeline;
  std::optional<std::string> source;            // frame selector (see SelectFrames)
  std::optional<std::string> target;            // frame selector
  std::optional<std::filesystem::path> mesh;    // geometry file when not recorded with the session
  std::optional<std::string> target_light;      // FRAME selector, SH .json or environment map
  std::map<std::string, std::string> settings;  // --set key=value: the pipeline's quality knobs
  bool explain = false;                         // plan only: decide and print, run nothing expensive
  bool reuse = true;                            // false: recompute every stage (--force)
  // Where the stages live (stage_cache.h). Null: a StageCache in out_dir/stages (kept and reused
  // by later runs, `reuse` as above); a TemporaryStageStore keeps nothing after the run. Shared:
  // when every pipeline runs, they all use this one store.
  std::shared_ptr<StageStore> store;
  // Evaluation only: loads the session's ground truth (core/truth.h), which compare_truth and the
  // floors (input=truth, true_normals, ...) use. Empty, or returning null: the session has none,
  // as real captures do. The CLI, batch and Python set rig::LoadSessionTruth (rig/session_truth.h),
  // which reads a simulated session's stored world; the pipelines themselves never reach the
  // simulator.
  std::function<std::shared_ptr<const SessionTruth>(const std::filesystem::path& session_dir)> load_truth;
};

// A planner decision, logged with its reason: "run", "reuse", "skip", "choose", "plan", "note"
// or "warn". `cache`: a stage cache event (RunStage's "run" or "reuse"), which the CLI counts
// instead of printing.
struct Decision {
  std::string stage;
  std::string action;
  std::string reason;
  bool cache = false;
};

class PipelineRun {
 public:
  PipelineRun(const PipelineRequest& request, const capture::SessionReader& session,
              std::shared_ptr<const SessionTruth> truth);

  const PipelineRequest& request() const { return request_; }
  const capture::SessionReader& session() const { return session_; }
  // The session's ground truth, for evaluation only (PipelineRequest::load_truth); null for real
  // captures and when the request loads none.
  const SessionTruth* truth() const { return truth_.get(); }
  StageStore& store() { return *store_; }
  // The session's scene model (its latest scene_model row, core/scene_model.h): the cameras,
  // geometry and lamps processing uses. Null when the session has none. Read once; IoError when
  // the row is unreadable.
  const SceneModel* scene_model();
  // That row's JSON ("" when there is none), for stage keys.
  const std::string& scene_model_json();
  // The pose and intrinsics of session device `device_id` from the scene model. Throws
  // InvalidArgumentError saying what to add when the session has no scene model or the model
  // no camera for the device; `purpose` says what needs it ("the irm pipeline's source view").
  const SceneModelCamera& RequireCamera(const std::string& device_id, const std::string& purpose);
  const std::filesystem::path& out_dir() const { return request_.out_dir; }
  // The undistortion maps of a lens (calibration/undistort.h), built on first use and kept for
  // the run: every frame of a camera shares them. Throws as Undistorter's constructor does.
  const calibration::Undistorter& LensUndistorter(const PinholeIntrinsics& intrinsics,
                                                  const std::vector<double>& distortion);

  // --set keys no ReadKnobs call used (noted in the summary).
  std::vector<std::string> UnusedSettings() const;
  // The pipeline's knobs (knobs.h) with the request's --set values applied. Each key used counts
  // as read (UnusedSettings), and the values go to summary.json ("knobs").
  template <typename Knobs>
  Knobs ReadKnobs() {
    Knobs knobs;
    std::set<std::string> used;
    ApplySettings(request_.settings, knobs, &used);
    for (const std::string& key : used) settings_read_[key] = true;
    knobs_json_.update(KnobsToJson(knobs));
    return knobs;
  }

  void Decide(const std::string& stage, const std::string& action, const std::string& reason);

  // Runs a stage through the cache and records "run" or "reuse" with the key's description.
  StageStore::Result RunStage(const std::string& stage, const StageKey& key,
                              const std::function<void(const std::filesystem::path&)>& produce);
  // Progress of long work on stderr, one line rewritten in place on a terminal (stage, items
  // done / total, rate, time elapsed and left); nothing when stderr is not a terminal.
  void Progress(const std::string& stage, std::int64_t done, std::int64_t total);

  void AddOutput(const std::filesystem::path& path, const std::string& what);

  // summary.json: the request, knobs, decisions, outputs and, as "metrics", the pipeline's summary
  // (`metrics`, its FieldsToJson) with the stage times.
  nlohmann::json Summary(double seconds, nlohmann::json metrics) const;
  const std::vector<Decision>& decisions() const { return decisions_; }

 private:
  const PipelineRequest& request_;
  const capture::SessionReader& session_;
  std::shared_ptr<const SessionTruth> truth_;
  std::shared_ptr<StageStore> store_;
  bool scene_model_read_ = false;
  std::optional<SceneModel> scene_model_;
  std::string scene_model_json_;
  std::string scene_model_row_;  // "calibration row N", for messages
  std::vector<Decision> decisions_;
  std::map<std::string, double> stage_seconds_;  // by stage, 0 when reused: metrics.stage_seconds
  nlohmann::json knobs_json_ = nlohmann::json::object();
  std::vector<std::pair<std::string, std::string>> outputs_;
  std::map<std::string, bool> settings_read_;
  // By intrinsics (width, height, fx, fy, cx, cy) followed by the coefficients.
  std::map<std::vector<double>, std::shared_ptr<const calibration::Undistorter>> undistorters_;
  std::chrono::steady_clock::time_point progress_start_;
  std::string progress_stage_;
};

// A stage output read from its file only when something asks for it: a rerun whose downstream
// stages are all reused reads none of the images its upstream stages wrote. Not thread-safe.
template <typename T>
class Lazy {
 public:
  Lazy() = default;
  explicit Lazy(std::function<T()> load) : load_(std::move(load)) {}
  const T& get() const {
    if (!value_) value_ = load_();
    return *value_;
  }

 private:
  std::function<T()> load_;
  mutable std::optional<T> value_;
};

// One figure of a pipeline's result, labelled, for the report: "relit vs truth, lit" "1.0" "%".
struct Figure {
  std::string label;
  std::string value;
  std::string unit;
};
// Appends a figure: fractions shown as per cent (unit "%"), other numbers with `digits`
// significant digits; a missing (nullopt) or non-finite value is left out.
void AddFigure(std::vector<Figure>& out, const std::string& label, std::optional<double> value, const std::string& unit,
               int digits = 4);
// A yes/no figure.
void AddYesNoFigure(std::vector<Figure>& out, const std::string& label, bool value);

// A pipeline with its typed summary: `Summary` has VisitFields (fields.h). `run` returns what the
// run measured (a default Summary when it planned only, PipelineRequest::explain); `headline` and
// `figures` read it, for a fresh run and for a summary.json an earlier run wrote alike.
template <typename Summary>
struct TypedPipeline {
  std::string name;
  std::string description;
  Summary (*run)(PipelineRun&);
  std::vector<KnobInfo> knobs;
  std::string (*headline)(const Summary&);
  std::vector<Figure> (*figures)(const Summary&);
  std::vector<std::string> stage_tags;
};

// A pipeline as the process command, the report and batch see it, whatever its summary's type:
// the summary crosses this edge as JSON (summary.json "metrics").
struct PipelineEntry {
  std::string name;
  std::string description;
  // Runs it; returns its summary as JSON (FieldsToJson).
  std::function<nlohmann::json(PipelineRun&)> run;
  std::vector<KnobInfo> knobs;  // its --set keys (knobs.h)
  // The run's headline figures in one sentence, from its summary (errors against the truth, what
  // was relit); empty when there is nothing to say. summary.json "headline", the CLI's last lines.
  // Throws IoError when `metrics` holds a field of the wrong type.
  std::function<std::string(const nlohmann::json& metrics)> headline;
  // Its key figures with labels and units, from its summary (the report's table).
  std::function<std::vector<Figure>(const nlohmann::json& metrics)> figures;
  // The stage names its AddKnobsToKey calls use (knobs.h); with "plan", "report" and "none", the
  // only tags its knobs may name.
  std::vector<std::string> stage_tags;
};

template <typename Summary>
PipelineEntry MakePipelineEntry(const TypedPipeline<Summary>& p) {
  const auto read = [](const nlohmann::json& metrics) {
    return FieldsFromJson<Summary>(metrics, "summary.json \"metrics\"");
  };
  auto run = p.run;
  auto headline = p.headline;
  auto figures = p.figures;
  return {p.name,
          p.description,
          [run](PipelineRun& r) { return FieldsToJson(run(r)); },
          p.knobs,
          [headline, read](const nlohmann::json& metrics) { return headline(read(metrics)); },
          [figures, read](const nlohmann::json& metrics) { return figures(read(metrics)); },
          p.stage_tags};
}

// j[key] when j is an object holding key, else null: reading a summary that may lack a figure.
const nlohmann::json& Field(const nlohmann::json& j, const std::string& key);

// A fraction as per cent with `decimals` decimals: "12.35 %"; "n/a" for nullopt or non-finite.
std::string PercentText(std::optional<double> fraction, int decimals = 1);

// Every pipeline of this build (pipelines.cc).
const std::vector<PipelineEntry>& Pipelines();

// Checks --set keys before anything runs: each must be a knob of `pipeline` ("all": of some
// pipeline of this build). InvalidArgumentError naming the key, the closest knob name and where
// the knobs are listed (`relume process --list --pipeline NAME`).
void CheckSettings(const std::map<std::string, std::string>& settings, const std::string& pipeline);

// Frames of the session matching a selector: a frame id ("42"), a range of ids ("3-12"), a bracket ("bracket:3"), a
// device's stream ("rgbd:color", "dslr:still"), or "all". InvalidArgumentError naming the
// selector and what the session has when nothing matches.
std::vector<capture::FrameRecord> SelectFrames(const capture::SessionReader& session, const std::string& selector);

// What to do about a session without a scene model: "an older simulated session gets one with
// `relume session add-scene-model S`; for real devices write one (docs/real-data.md)".
std::string SceneModelAdvice(const std::filesystem::path& session_dir);

// The file that marks a folder as relume's output: `relume process` writes only into a new or
// empty folder, one it marked, or one an older relume wrote (stages/, summary.json).
inline constexpr const char* kOutputMarker = ".relume-output";

// Checks and creates an output folder: refused inside a session's recorded data or when it is a
// session (capture/path_policy.h), or when it holds files relume did not write
// (InvalidArgumentError naming one); marked as relume's when it is not yet.
void PrepareOutputFolder(const std::filesystem::path& folder);

// Runs one pipeline end to end: opens the session, loads its rig, prepares and locks out_dir
// (a second run into the same folder at once is refused: capture/folder_lock.h), runs, writes
// summary.json into out_dir and returns the summary.
nlohmann::json RunPipeline(const PipelineRequest& request);

}  // namespace relume::pipeline
