#include "batch/batch.h"

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <thread>

#include "batch/local_backend.h"
#include "batch/plan.h"
#include "batch/slurm_backend.h"
#include "capture/durable_file.h"
#include "capture/folder_lock.h"
#include "capture/path_policy.h"
#include "core/error.h"
#include "core/time.h"

namespace relume::batch {
namespace fs = std::filesystem;

namespace {

constexpr const char* kMarker = ".relume-batch";

// What batch.json says of one task: its last attempt and how that ended for the backend.
struct Attempt {
  std::string id;       // "local-..." or "slurm-<job>"; empty: never run under this plan
  std::string backend;  // "local" or "slurm"
  std::string job_id;
  std::string log;  // relative to the batch folder
  std::string end;  // empty while it may still run
};

struct State {
  std::string plan;  // relative to the batch folder
  std::vector<Attempt> tasks;
};

State ReadState(const fs::path& out_dir) {
  State state;
  if (!fs::exists(out_dir / kStateFile)) return state;
  const nlohmann::json j = ReadJson(out_dir / kStateFile);
  state.plan = j.value("plan", "");
  for (const nlohmann::json& t : j.value("tasks", nlohmann::json::array())) {
    state.tasks.push_back({t.value("attempt", ""), t.value("backend", ""), t.value("job_id", ""), t.value("log", ""),
                           t.value("end", "")});
  }
  return state;
}

void WriteState(const fs::path& out_dir, const State& state) {
  nlohmann::json j;
  j["format"] = "relume-batch-1";
  j["plan"] = state.plan;
  j["tasks"] = nlohmann::json::array();
  for (const Attempt& a : state.tasks) {
    j["tasks"].push_back(
        {{"attempt", a.id}, {"backend", a.backend}, {"job_id", a.job_id}, {"log", a.log}, {"end", a.end}});
  }
  WriteJsonDurably(out_dir / kStateFile, j);
}

// Refuses a folder that is not a batch's (files of the user's in it) and makes it one.
void PrepareBatchFolder(const fs::path& out_dir) {
  capture::CheckOutputFolder(out_dir, "--out");
  std::error_code ec;
  if (fs::is_directory(out_dir, ec) && !fs::exists(out_dir / kMarker, ec) && !fs::is_empty(out_dir, ec)) {
    throw InvalidArgumentError("--out " + out_dir.string() +
                               ": the folder exists and is not a relume batch folder (no " + kMarker +
                               "); name a new or empty folder");
  }
  capture::CreateDirectoryDurably(out_dir);
  capture::CreateDirectoryDurably(out_dir / "logs");
  if (!fs::exists(out_dir / kMarker)) {
    WriteJsonDurably(out_dir / kMarker, {{"written_by", "relume batch"}, {"docs", "docs/batch.md"}});
  }
}

std::string CompactUtcNow() {
  std::string text = FormatIso8601(std::chrono::time_point_cast<Nanoseconds>(UtcNow()), std::chrono::seconds{0}, 0);
  std::string out;
  for (const char c : text) {
    if (c != '-' && c != ':') out += c;
  }
  return out;  // 20261203T031500Z
}

bool ProcessAlive(long pid) {
  return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM);
}

std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0) return "";
  return name;
}

void ReadResult(const fs::path& out_dir, const BatchTask& task, TaskOutcome& outcome) {
  const fs::path result = out_dir / task.folder / kResultFolder;
  nlohmann::json j;
  try {
    j = ReadJson(result / kResultRecordFile);
  } catch (const Error&) {
    return;
  }
  const std::string report = j.value("report", "");
  if (!report.empty()) outcome.report = (fs::path(task.folder) / kResultFolder / report).string();
  for (const nlohmann::json& p : j.value("pipelines", nlohmann::json::array())) {
    PipelineOutcome po;
    po.name = p.value("name", "");
    po.headline = p.value("headline", "");
    po.error = p.value("error", "");
    for (const nlohmann::json& f : p.value("figures", nlohmann::json::array())) {
      po.figures.push_back({f.value("label", ""), f.value("value", ""), f.value("unit", "")});
    }
    outcome.pipelines.push_back(std::move(po));
  }
}

// One task's outcome from what the backend saw (the attempt) and what the task recorded.
TaskOutcome Outcome(const fs::path& out_dir, const BatchTask& task, const Attempt& attempt) {
  TaskOutcome o;
  o.index = task.index;
  o.session = task.session.string();
  o.folder = task.folder;
  o.attempt = attempt.id;
  o.backend_state = attempt.end;
  o.log = attempt.log;
  if (attempt.id.empty()) return o;  // kNotRun
  const TaskRecord record = ReadTaskRecord(out_dir / task.folder);
  const bool mine = record.attempt == attempt.id;
  const bool finished = mine && (record.state == TaskState::kDone || record.state == TaskState::kFailed);
  if (finished) {
    o.state = record.state;
    o.message = record.message;
    o.seconds = record.seconds;
    if (o.state == TaskState::kDone && !fs::is_directory(out_dir / task.folder / kResultFolder)) {
      o.state = TaskState::kFailed;
      o.message = "recorded as done but its result folder is missing";
    }
    ReadResult(out_dir, task, o);
    return o;
  }
  if (attempt.end.empty()) {
    o.state = mine && record.state == TaskState::kRunning ? TaskState::kRunning : TaskState::kQueued;
    return o;
  }
  o.state = TaskState::kFailed;
  o.message = "ended without a result (" + (attempt.backend == "slurm" ? "Slurm: " + attempt.end : attempt.end) +
              (mine ? ", while running" : ", before it started") +
              "); nothing was published, and a rerun continues from its completed stages";
  return o;
}

BatchSummary Gather(const fs::path& out_dir, const BatchPlan& plan, const State& state) {
  BatchSummary summary;
  summary.out_dir = out_dir;
  for (const BatchTask& task : plan.tasks) {
    const std::size_t i = static_cast<std::size_t>(task.index);
    summary.tasks.push_back(Outcome(out_dir, task, i < state.tasks.size() ? state.tasks[i] : Attempt{}));
  }
  return summary;
}

// A local attempt whose batch process is gone (stopped or killed) ended when its worker did.
void SettleOrphanedLocalTasks(const fs::path& out_dir, const BatchPlan& plan, State& state) {
  const std::string host = HostName();
  for (const BatchTask& task : plan.tasks) {
    Attempt& a = state.tasks[static_cast<std::size_t>(task.index)];
    if (a.backend != "local" || !a.end.empty() || a.id.empty()) continue;
    const TaskRecord record = ReadTaskRecord(out_dir / task.folder);
    if (record.attempt != a.id) {
      a.end = "not started (the batch stopped first)";
    } else if (record.state != TaskState::kRunning) {
      a.end = "ended";
    } else if (record.host == host && !ProcessAlive(record.pid)) {
      a.end = "its worker (pid " + std::to_string(record.pid) + ") is gone";
    }
  }
}

// Polls Slurm until no task of the plan submitted as `job_id` may still run (or once, without
// `wait`), recording each task's end in `state` (saved as it changes). A task Slurm no longer
// knows, whose record does not say it ended, is given up after three polls that know nothing of
// the whole job (one without `wait`: the caller has just asked and found nothing active).
void FollowSlurmJob(const fs::path& out_dir, const BatchPlan& plan, State& state, const std::string& job_id,
                    const SlurmOptions& slurm, bool wait, const BatchCallbacks& callbacks) {
  int polls_unknown = 0;
  // Polls since Slurm said a task ended while its record did not say so yet (a shared
  // filesystem may show the task's last write late).
  std::map<int, int> polls_unrecorded;
  for (;;) {
    const std::map<int, std::string> states = ArrayTaskStates(slurm, job_id);
    polls_unknown = states.empty() ? polls_unknown + 1 : 0;
    bool active = false;
    bool changed = false;
    for (const BatchTask& task : plan.tasks) {
      Attempt& a = state.tasks[static_cast<std::size_t>(task.index)];
      if (a.job_id != job_id || !a.end.empty()) continue;
      const auto it = states.find(task.index);
      if (it != states.end() && IsActiveSlurmState(it->second)) {
        active = true;
        continue;
      }
      if (it == states.end()) {
        // Forgotten by the controller (MinJobAge) with no accounting: trust the task's record, or
        // give up after a few polls that know nothing of the whole job.
        const TaskRecord record = ReadTaskRecord(out_dir / task.folder);
        const bool recorded = record.attempt == a.id && record.state != TaskState::kRunning;
        if (!recorded && polls_unknown < (wait ? 3 : 1)) {
          active = true;
          continue;
        }
        a.end = recorded ? "ended" : "unknown to Slurm";
      } else {
        const TaskRecord record = ReadTaskRecord(out_dir / task.folder);
        const bool recorded = record.attempt == a.id && record.state != TaskState::kRunning;
        if (it->second == "COMPLETED" && !recorded && ++polls_unrecorded[task.index] < 5) {
          active = true;
          continue;
        }
        a.end = it->second;
      }
      changed = true;
      if (callbacks.on_task_end) callbacks.on_task_end(Outcome(out_dir, task, a));
    }
    if (changed) WriteState(out_dir, state);
    if (!active || !wait) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(slurm.poll_interval_s));
  }
}

// Refuses to start while a Slurm job of this batch may still run a task.
void CheckNoActiveJob(const fs::path& out_dir, const State& state, const SlurmOptions& slurm) {
  std::set<std::string> jobs;
  for (const Attempt& a : state.tasks) {
    if (a.backend == "slurm" && a.end.empty()) jobs.insert(a.job_id);
  }
  for (const std::string& job : jobs) {
    for (const auto& [index, s] : ArrayTaskStates(slurm, job)) {
      if (!IsActiveSlurmState(s)) continue;
      throw InvalidArgumentError("Slurm job " + job + " of the batch in " + out_dir.string() + " still has task " +
                                 std::to_string(index) + " " + s + "; wait for it (relume batch --out " +
                                 out_dir.string() + " --collect --wait) or cancel it (scancel " + job + ")");
    }
  }
}

BatchPlan LoadCurrentPlan(const fs::path& out_dir, const State& state) {
  if (state.plan.empty()) {
    throw InvalidArgumentError("--out " + out_dir.string() +
                               ": no batch has run there yet (no batch.json); start one with session folders");
  }
  return ReadPlan(out_dir / state.plan);
}

}  // namespace

BatchSummary RunBatch(const BatchOptions& options, const BatchCallbacks& callbacks) {
  ThrowIfInvalid(options, "relume batch");
  const auto start = std::chrono::steady_clock::now();
  const fs::path out_dir = fs::absolute(options.out_dir).lexically_normal();
  PrepareBatchFolder(out_dir);
  const capture::FolderLock lock = capture::FolderLock::Acquire(out_dir, "batch");
  State state = ReadState(out_dir);
  CheckNoActiveJob(out_dir, state, options.slurm);

  BatchPlan plan;
  std::vector<int> indices;
  if (options.only_failed) {
    plan = LoadCurrentPlan(out_dir, state);
    state.tasks.resize(plan.tasks.size());
    SettleOrphanedLocalTasks(out_dir, plan, state);
    // A job submitted without waiting and never collected: its tasks ended (CheckNoActiveJob).
    std::set<std::string> jobs;
    for (const Attempt& a : state.tasks) {
      if (a.backend == "slurm" && a.end.empty()) jobs.insert(a.job_id);
    }
    for (const std::string& job : jobs) FollowSlurmJob(out_dir, plan, state, job, options.slurm, false, {});
    indices = Gather(out_dir, plan, state).Unfinished();
  } else {
    const bool all = options.request.pipeline.empty() || options.request.pipeline == "all";
    if (!all && std::none_of(pipeline::Pipelines().begin(), pipeline::Pipelines().end(),
                             [&](const pipeline::PipelineEntry& e) { return e.name == options.request.pipeline; })) {
      throw InvalidArgumentError("--pipeline " + options.request.pipeline +
                                 ": no such pipeline (`relume process --list` names them)");
    }
    pipeline::CheckSettings(options.request.settings, all ? "all" : options.request.pipeline);
    plan = MakePlan(options.sessions, options.request);
    state.plan = fs::relative(WritePlan(plan, out_dir), out_dir).string();
    state.tasks.assign(plan.tasks.size(), Attempt{});
    for (const BatchTask& t : plan.tasks) indices.push_back(t.index);
  }
  const fs::path plan_file = out_dir / state.plan;

  BatchSummary summary;
  if (indices.empty()) {
    WriteState(out_dir, state);
  } else if (options.backend == Backend::kLocal) {
    const std::string attempt = "local-" + CompactUtcNow() + "-" + std::to_string(::getpid());
    for (const int i : indices) {
      state.tasks[static_cast<std::size_t>(i)] = {attempt, "local", "",
                                                  "logs/" + attempt + "_" + std::to_string(i) + ".log", ""};
    }
    WriteState(out_dir, state);
    if (callbacks.on_started) callbacks.on_started(attempt, "", indices);
    RunLocalTasks(
        indices, options.local_workers, options.local_start, options.task_command, plan_file, attempt,
        [&](int i) { return out_dir / state.tasks[static_cast<std::size_t>(i)].log; },
        [&](int i, const std::string& how) {
          Attempt& a = state.tasks[static_cast<std::size_t>(i)];
          a.end = how;
          WriteState(out_dir, state);
          if (callbacks.on_task_end)
            callbacks.on_task_end(Outcome(out_dir, plan.tasks[static_cast<std::size_t>(i)], a));
        });
    summary.attempt = attempt;
  } else {
    capture::CreateDirectoryDurably(out_dir / "slurm");
    const fs::path script = out_dir / "slurm" / ("job-" + CompactUtcNow() + ".sh");
    const std::string text =
        JobScript(options.slurm, options.task_command, plan_file, out_dir / "logs", "relume-batch");
    capture::WriteFileDurably(script, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
    const std::string job_id = SubmitArray(options.slurm, script, ArraySpec(indices, options.slurm.max_running_tasks));
    const std::string attempt = "slurm-" + job_id;
    for (const int i : indices) {
      state.tasks[static_cast<std::size_t>(i)] = {attempt, "slurm", job_id,
                                                  "logs/slurm-" + job_id + "_" + std::to_string(i) + ".log", ""};
    }
    WriteState(out_dir, state);
    if (callbacks.on_started) callbacks.on_started(attempt, job_id, indices);
    FollowSlurmJob(out_dir, plan, state, job_id, options.slurm, options.slurm.wait, callbacks);
    summary.attempt = attempt;
    summary.job_id = job_id;
    summary.waited = options.slurm.wait;
  }

  BatchSummary gathered = Gather(out_dir, plan, state);
  gathered.backend = BackendName(options.backend);
  gathered.attempt = summary.attempt;
  gathered.job_id = summary.job_id;
  gathered.waited = summary.waited;
  gathered.run = indices;
  gathered.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  WriteIndex(gathered);
  return gathered;
}

BatchSummary CollectBatch(const fs::path& out_dir_in, const SlurmOptions& slurm, bool wait,
                          const BatchCallbacks& callbacks) {
  const fs::path out_dir = fs::absolute(out_dir_in).lexically_normal();
  if (!fs::exists(out_dir / kMarker)) {
    throw InvalidArgumentError("--out " + out_dir.string() + ": not a relume batch folder (no " + kMarker + ")");
  }
  const capture::FolderLock lock = capture::FolderLock::Acquire(out_dir, "batch --collect");
  State state = ReadState(out_dir);
  const BatchPlan plan = LoadCurrentPlan(out_dir, state);
  state.tasks.resize(plan.tasks.size());
  SettleOrphanedLocalTasks(out_dir, plan, state);
  std::set<std::string> jobs;
  std::string backend = "local";
  for (const Attempt& a : state.tasks) {
    if (a.backend == "slurm") backend = "slurm";
    if (a.backend == "slurm" && a.end.empty()) jobs.insert(a.job_id);
  }
  for (const std::string& job : jobs) FollowSlurmJob(out_dir, plan, state, job, slurm, wait, callbacks);
  WriteState(out_dir, state);
  BatchSummary summary = Gather(out_dir, plan, state);
  summary.backend = backend;
  summary.waited = wait;
  if (!jobs.empty()) summary.job_id = *jobs.rbegin();
  WriteIndex(summary);
  return summary;
}

}  // namespace relume::batch
