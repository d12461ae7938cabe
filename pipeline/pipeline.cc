#include "pipeline/pipeline.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <span>
#include <tuple>

#include "calibration/undistort.h"
#include "capture/durable_file.h"
#include "capture/folder_lock.h"
#include "capture/path_policy.h"
#include "capture/scene_model_record.h"
#include "core/error.h"

namespace relume::pipeline {
namespace fs = std::filesystem;

PipelineRun::PipelineRun(const PipelineRequest& request, const capture::SessionReader& session,
                         std::shared_ptr<const SessionTruth> truth)
    : request_(request),
      session_(session),
      truth_(std::move(truth)),
      store_(request.store ? request.store : std::make_shared<StageCache>(request.out_dir / "stages", request.reuse)) {
  for (const auto& [key, value] : request_.settings) settings_read_[key] = false;
}

std::string SceneModelAdvice(const fs::path& session_dir) {
  return "sessions captured from a simulated rig by this relume have one; an older simulated session gets one with "
         "`relume session add-scene-model " +
         session_dir.string() + "`; for real devices write one and store it with `relume session add-scene-model " +
         session_dir.string() + " --from FILE` (docs/real-data.md)";
}

const SceneModel* PipelineRun::scene_model() {
  if (!scene_model_read_) {
    scene_model_read_ = true;
    const std::vector<capture::CalibrationRecord> rows = session_.Calibrations();
    if (const capture::CalibrationRecord* row = capture::LatestSceneModelRow(rows)) {
      scene_model_row_ = "calibration row " + std::to_string(row->id);
      scene_model_ = capture::SceneModelFromJson(row->json, session_.dir().string() + ": " + scene_model_row_);
      scene_model_json_ = row->json;
    }
  }
  return scene_model_ ? &*scene_model_ : nullptr;
}

const std::string& PipelineRun::scene_model_json() {
  scene_model();
  return scene_model_json_;
}

const calibration::Undistorter& PipelineRun::LensUndistorter(const PinholeIntrinsics& intrinsics,
                                                             const std::vector<double>& distortion) {
  std::vector<double> key = {static_cast<double>(intrinsics.width),
                             static_cast<double>(intrinsics.height),
                             intrinsics.fx,
                             intrinsics.fy,
                             intrinsics.cx,
                             intrinsics.cy};
  key.insert(key.end(), distortion.begin(), distortion.end());
  std::shared_ptr<const calibration::Undistorter>& slot = undistorters_[key];
  if (slot == nullptr) slot = std::make_shared<const calibration::Undistorter>(intrinsics, distortion);
  return *slot;
}

const SceneModelCamera& PipelineRun::RequireCamera(const std::string& device_id, const std::string& purpose) {
  const SceneModel* model = scene_model();
  if (model == nullptr) {
    throw InvalidArgumentError(
        purpose + " needs the pose and intrinsics of camera " + device_id + ", and session " + session_.dir().string() +
        " has no scene model (`relume session info` shows it): " + SceneModelAdvice(session_.dir()));
  }
  const SceneModelCamera* camera = model->FindCamera(device_id);
  if (camera == nullptr) {
    std::string have;
    for (const SceneModelCamera& c : model->cameras) have += (have.empty() ? "" : ", ") + c.device_id;
    throw InvalidArgumentError(
        purpose + " needs the pose and intrinsics of camera " + device_id + ", and the scene model (" +
        scene_model_row_ + ") has none for it (it has " + (have.empty() ? "no camera" : have) +
        "); add the camera to a scene model file and store it with `relume session add-scene-model " +
        session_.dir().string() + " --from FILE` (docs/real-data.md)");
  }
  if (!camera->has_pose) {
    throw InvalidArgumentError(purpose + ": camera " + device_id +
                               " has calibrated intrinsics but no pose in the scene "
                               "model (" +
                               scene_model_row_ + "); give it one with `relume calibrate pose --session " +
                               session_.dir().string() + " --device " + device_id + " --gcp FILE` (docs/real-data.md)");
  }
  Decide("scene", "note",
         "camera " + device_id + " from the scene model (" + scene_model_row_ + "): " + camera->source +
             (calibration::HasDistortion(camera->distortion)
                  ? "; its frames are undistorted onto this pinhole camera (calibration/undistort.h)"
                  : ""));
  return *camera;
}

std::vector<std::string> PipelineRun::UnusedSettings() const {
  std::vector<std::string> unused;
  for (const auto& [key, read] : settings_read_) {
    if (!read) unused.push_back(key);
  }
  return unused;
}

void PipelineRun::Decide(const std::string& stage, const std::string& action, const std::string& reason) {
  decisions_.push_back({stage, action, reason});
  spdlog::debug("{} {} {}", stage, action, reason);
}

StageStore::Result PipelineRun::RunStage(const std::string& stage, const StageKey& key,
                                         const std::function<void(const fs::path&)>& produce) {
  const auto start = std::chrono::steady_clock::now();
  StageStore::Result result = store_->Run(stage, key, produce);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (result.reused) {
    Decide(stage, "reuse", "inputs and settings unchanged (key " + result.key.substr(0, 12) + ")");
  } else {
    char text[32];
    std::snprintf(text, sizeof(text), "%.2f s", seconds);
    Decide(stage, "run", std::string("computed in ") + text + " (key " + result.key.substr(0, 12) + ")");
  }
  decisions_.back().cache = true;
  stage_seconds_[stage] = result.reused ? 0.0 : seconds;
  return result;
}

void PipelineRun::Progress(const std::string& stage, std::int64_t done, std::int64_t total) {
  static const bool terminal = ::isatty(STDERR_FILENO) != 0;
  if (!terminal) return;  // a live line only; logs and pipes get the summary
  const auto now = std::chrono::steady_clock::now();
  if (stage != progress_stage_) {
    progress_stage_ = stage;
    progress_start_ = now;
  }
  const double elapsed = std::chrono::duration<double>(now - progress_start_).count();
  const double rate = elapsed > 0.0 ? static_cast<double>(done) / elapsed : 0.0;
  const double left = rate > 0.0 ? static_cast<double>(total - done) / rate : 0.0;
  std::fprintf(stderr, "\r%-14s %lld/%lld  %.1f/s  %.0f s elapsed, %.0f s left   ", stage.c_str(),
               static_cast<long long>(done), static_cast<long long>(total), rate, elapsed, left);
  if (done >= total) std::fprintf(stderr, "\n");
}

void PipelineRun::AddOutput(const fs::path& path, const std::string& what) {
  // Relative to the output folder when inside it; absolute otherwise (a store elsewhere).
  const fs::path relative = fs::relative(path, request_.out_dir);
  const bool inside = !relative.empty() && *relative.begin() != "..";
  outputs_.emplace_back(inside ? relative.string() : fs::absolute(path).string(), what);
}

nlohmann::json PipelineRun::Summary(double seconds, nlohmann::json metrics) const {
  nlohmann::json summary;
  summary["pipeline"] = request_.pipeline;
  summary["session"] = fs::absolute(request_.session_dir).string();
  summary["explain"] = request_.explain;
  summary["seconds"] = seconds;
  summary["stages"] = store_->Describe();
  summary["settings"] = request_.settings;
  summary["knobs"] = knobs_json_;
  summary["decisions"] = nlohmann::json::array();
  for (const Decision& d : decisions_) {
    nlohmann::json j = {{"stage", d.stage}, {"action", d.action}, {"reason", d.reason}};
    if (d.cache) j["cache"] = true;
    summary["decisions"].push_back(std::move(j));
  }
  summary["outputs"] = nlohmann::json::array();
  for (const auto& [path, what] : outputs_) summary["outputs"].push_back({{"path", path}, {"what", what}});
  if (!metrics.is_object()) metrics = nlohmann::json::object();
  if (!stage_seconds_.empty()) metrics["stage_seconds"] = stage_seconds_;
  summary["metrics"] = std::move(metrics);
  return summary;
}

namespace {

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

const nlohmann::json& Field(const nlohmann::json& j, const std::string& key) {
  static const nlohmann::json null_json;
  if (!j.is_object()) return null_json;
  const auto it = j.find(key);
  return it == j.end() ? null_json : *it;
}

std::string PercentText(std::optional<double> fraction, int decimals) {
  if (!fraction || !std::isfinite(*fraction)) return "n/a";
  char text[48];
  std::snprintf(text, sizeof(text), "%.*f %%", decimals, 100.0 * *fraction);
  return text;
}

void AddFigure(std::vector<Figure>& out, const std::string& label, std::optional<double> value, const std::string& unit,
               int digits) {
  if (!value || !std::isfinite(*value)) return;
  char text[48];
  if (unit == "%") {
    std::snprintf(text, sizeof(text), "%.2f", 100.0 * *value);
  } else {
    std::snprintf(text, sizeof(text), "%.*g", digits, *value);
  }
  out.push_back({label, text, unit});
}

void AddYesNoFigure(std::vector<Figure>& out, const std::string& label, bool value) {
  out.push_back({label, value ? "yes" : "no", ""});
}

void CheckSettings(const std::map<std::string, std::string>& settings, const std::string& pipeline) {
  const bool all = pipeline.empty() || pipeline == "all";
  std::set<std::string> knobs;
  for (const PipelineEntry& entry : Pipelines()) {
    if (!all && entry.name != pipeline) continue;
    for (const KnobInfo& k : entry.knobs) knobs.insert(k.name);
  }
  for (const auto& [key, value] : settings) {
    if (knobs.contains(key)) continue;
    std::string closest;
    std::size_t best = 4;  // suggest only names within 3 edits
    for (const std::string& k : knobs) {
      const std::size_t d = EditDistance(key, k);
      if (d < best) {
        best = d;
        closest = k;
      }
    }
    const std::string where = all ? "any pipeline" : "the " + pipeline + " pipeline";
    throw InvalidArgumentError("--set " + key + "=" + value + ": not a knob of " + where +
                               (closest.empty() ? std::string() : " (did you mean " + closest + "?)") +
                               "; `relume process --list --pipeline " + (all ? std::string("NAME") : pipeline) +
                               "` lists " + (all ? "a pipeline's" : "its") + " knobs with their defaults");
  }
}

std::vector<capture::FrameRecord> SelectFrames(const capture::SessionReader& session, const std::string& selector) {
  const std::vector<capture::FrameRecord> frames = session.Frames();
  std::vector<capture::FrameRecord> selected;
  if (selector == "all") return frames;
  if (selector.rfind("bracket:", 0) == 0) {
    std::int64_t id = 0;
    const std::string number = selector.substr(8);
    const auto [ptr, ec] = std::from_chars(number.data(), number.data() + number.size(), id);
    if (ec != std::errc() || ptr != number.data() + number.size()) {
      throw InvalidArgumentError("frame selector '" + selector + "': bracket:N takes a bracket id");
    }
    for (const capture::FrameRecord& f : frames) {
      if (f.bracket_id == id) selected.push_back(f);
    }
  } else if (const std::size_t colon = selector.rfind(':'); colon != std::string::npos) {
    const std::string device = selector.substr(0, colon);
    const std::string stream = selector.substr(colon + 1);
    for (const capture::FrameRecord& f : frames) {
      const bool device_matches = f.device_id == device || f.device_id.ends_with(":" + device);
      if (device_matches && f.stream == stream) selected.push_back(f);
    }
  } else {
    // A frame id, or a range of them (first-last, inclusive).
    std::int64_t first = 0, last = 0;
    const char* end = selector.data() + selector.size();
    std::from_chars_result parsed = std::from_chars(selector.data(), end, first);
    last = first;
    if (parsed.ec == std::errc() && parsed.ptr != end && *parsed.ptr == '-') {
      parsed = std::from_chars(parsed.ptr + 1, end, last);
    }
    if (parsed.ec != std::errc() || parsed.ptr != end || last < first) {
      throw InvalidArgumentError("frame selector '" + selector +
                                 "': give a frame id (42), a range of frame ids (3-12), a bracket (bracket:3), a "
                                 "device stream (rgbd:color) or all");
    }
    for (const capture::FrameRecord& f : frames) {
      if (f.id >= first && f.id <= last) selected.push_back(f);
    }
  }
  if (selected.empty()) {
    std::string have;
    for (const capture::BracketRecord& b : session.Brackets())
      have += (have.empty() ? "" : ", ") + std::to_string(b.id);
    throw InvalidArgumentError("frame selector '" + selector + "' matches no frame of " + session.dir().string() +
                               " (frame ids 1.." + std::to_string(frames.size()) + ", brackets " +
                               (have.empty() ? "none" : have) + "; see `relume session info`)");
  }
  return selected;
}

void PrepareOutputFolder(const fs::path& folder) {
  capture::CheckOutputFolder(folder, "--out");
  std::error_code ec;
  if (fs::is_directory(folder, ec) && !fs::exists(folder / kOutputMarker, ec)) {
    // Output folders of relume releases before the marker hold these; anything else is the
    // user's, and a run would overwrite same-named files in it.
    for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
      const std::string name = entry.path().filename().string();
      if (name == "stages" || name == "summary.json" || name == "report.html" || name == capture::kLockFileName) {
        continue;
      }
      if (entry.is_directory() && (fs::exists(entry.path() / "summary.json") || fs::exists(entry.path() / "stages") ||
                                   fs::exists(entry.path() / kOutputMarker))) {
        continue;  // a pipeline's folder
      }
      throw InvalidArgumentError("--out " + folder.string() + ": the folder exists and holds files relume did not " +
                                 "write (e.g. " + name + "); name a new or empty folder");
    }
  }
  fs::create_directories(folder, ec);
  if (ec) throw IoError(folder.string(), "cannot create the output folder: " + ec.message());
  if (!fs::exists(folder / kOutputMarker)) {
    static constexpr std::string_view kText = "relume process writes this folder; it may replace any file in it\n";
    capture::WriteFileDurably(folder / kOutputMarker,
                              std::span(reinterpret_cast<const std::uint8_t*>(kText.data()), kText.size()));
  }
}

nlohmann::json RunPipeline(const PipelineRequest& request) {
  const PipelineEntry* entry = nullptr;
  std::string names;
  for (const PipelineEntry& e : Pipelines()) {
    names += (names.empty() ? "" : ", ") + e.name;
    if (e.name == request.pipeline) entry = &e;
  }
  if (entry == nullptr) {
    throw InvalidArgumentError("no pipeline named '" + request.pipeline +
                               "' (this build has: " + (names.empty() ? "none" : names) + ")");
  }
  if (!fs::exists(request.session_dir / capture::kSessionDatabaseName)) {
    throw IoError(request.session_dir.string(), std::string("is not a relume session (no ") +
                                                    capture::kSessionDatabaseName +
                                                    "); record one with `relume capture`");
  }
  // A typo is refused; a knob of another pipeline is noted below (one --set serves every
  // pipeline when `relume process` runs them all).
  CheckSettings(request.settings, "all");
  const capture::SessionReader session(request.session_dir);
  std::shared_ptr<const SessionTruth> truth = request.load_truth ? request.load_truth(request.session_dir) : nullptr;
  PrepareOutputFolder(request.out_dir);
  // One writer per output folder: a second `relume process` into it is refused, not interleaved.
  const capture::FolderLock lock = capture::FolderLock::Acquire(request.out_dir, "process " + request.pipeline);

  PipelineRun run(request, session, truth);
  if (!truth)
    run.Decide("session", "note", "no ground truth for this session (a real capture): nothing is compared with truth");
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json metrics = entry->run(run);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const std::string& key : run.UnusedSettings()) {
    run.Decide("settings", "note", "--set " + key + " is not a knob of the " + request.pipeline + " pipeline; ignored");
  }
  nlohmann::json summary = run.Summary(seconds, std::move(metrics));
  if (entry->headline && !request.explain) {
    const std::string headline = entry->headline(summary["metrics"]);
    if (!headline.empty()) summary["headline"] = headline;
  }
  if (!request.explain) {
    const std::string text = summary.dump(2) + "\n";
    capture::WriteFileDurably(request.out_dir / "summary.json",
                              std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  }
  return summary;
}

}  // namespace relume::pipeline
