#include "batch/task.h"

#include <unistd.h>

#include <chrono>
#include <iostream>

#include "batch/plan.h"
#include "capture/durable_file.h"
#include "capture/folder_lock.h"
#include "core/error.h"
#include "core/time.h"
#include "pipeline/process.h"
#include "rig/session_truth.h"

namespace relume::batch {
namespace fs = std::filesystem;

const char* TaskStateName(TaskState state) {
  switch (state) {
    case TaskState::kNotRun: return "not run";
    case TaskState::kQueued: return "queued";
    case TaskState::kRunning: return "running";
    case TaskState::kDone: return "done";
    case TaskState::kFailed: return "failed";
  }
  return "not run";
}

TaskState TaskStateFromName(const std::string& name) {
  for (const TaskState s : {TaskState::kQueued, TaskState::kRunning, TaskState::kDone, TaskState::kFailed}) {
    if (name == TaskStateName(s)) return s;
  }
  return TaskState::kNotRun;
}

nlohmann::json TaskRecordToJson(const TaskRecord& r) {
  return {{"state", TaskStateName(r.state)},
          {"index", r.index},
          {"attempt", r.attempt},
          {"session", r.session},
          {"host", r.host},
          {"pid", r.pid},
          {"started_utc", r.started_utc},
          {"ended_utc", r.ended_utc},
          {"seconds", r.seconds},
          {"message", r.message}};
}

TaskRecord TaskRecordFromJson(const nlohmann::json& j) {
  TaskRecord r;
  r.state = TaskStateFromName(j.value("state", ""));
  r.index = j.value("index", -1);
  r.attempt = j.value("attempt", "");
  r.session = j.value("session", "");
  r.host = j.value("host", "");
  r.pid = j.value("pid", 0L);
  r.started_utc = j.value("started_utc", "");
  r.ended_utc = j.value("ended_utc", "");
  r.seconds = j.value("seconds", 0.0);
  r.message = j.value("message", "");
  return r;
}

TaskRecord ReadTaskRecord(const fs::path& task_dir) {
  try {
    return TaskRecordFromJson(ReadJson(task_dir / kTaskRecordFile));
  } catch (const Error&) {
    return {};
  }
}

fs::path BeginResult(const fs::path& task_dir) {
  const fs::path result = task_dir / kResultFolder;
  const fs::path work = task_dir / kWorkFolder;
  std::error_code ec;
  const bool have_result = fs::is_directory(result, ec);
  const bool have_work = fs::is_directory(work, ec);
  if (have_result && have_work) {
    // Cannot follow from BeginResult/PublishResult (one rename each); keep the complete one.
    fs::remove_all(work, ec);
    if (ec) throw IoError(work.string(), "cannot remove the stale work folder: " + ec.message());
  }
  if (have_result) {
    fs::rename(result, work, ec);
    if (ec) throw IoError(result.string(), "cannot move the result into the work folder: " + ec.message());
    capture::SyncDirectory(task_dir);
  }
  fs::remove(work / kResultRecordFile, ec);
  return work;
}

fs::path PublishResult(const fs::path& task_dir) {
  const fs::path result = task_dir / kResultFolder;
  const fs::path work = task_dir / kWorkFolder;
  std::error_code ec;
  if (!fs::is_directory(work, ec)) throw IoError(work.string(), "no work folder to publish");
  capture::SyncDirectory(work);
  fs::rename(work, result, ec);
  if (ec) throw IoError(result.string(), "cannot publish the result: " + ec.message());
  capture::SyncDirectory(task_dir);
  return result;
}

namespace {

std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0) return "unknown";
  return name;
}

const pipeline::PipelineEntry* FindPipeline(const std::string& name) {
  for (const pipeline::PipelineEntry& e : pipeline::Pipelines()) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

// result.json: per pipeline its headline, key figures (the report's table) or why it did not run.
nlohmann::json ResultRecord(const pipeline::ProcessResult& processed, const TaskRecord& record, const fs::path& work) {
  nlohmann::json j;
  j["session"] = record.session;
  j["attempt"] = record.attempt;
  j["report"] = processed.report.empty() ? "" : fs::relative(processed.report, work).string();
  j["failed"] = processed.failed;
  j["pipelines"] = nlohmann::json::array();
  for (const pipeline::PipelineReport& r : processed.reports) {
    nlohmann::json p;
    p["name"] = r.name;
    p["error"] = r.error;
    p["headline"] = r.summary.is_object() ? r.summary.value("headline", "") : "";
    p["seconds"] = r.summary.is_object() ? r.summary.value("seconds", 0.0) : 0.0;
    p["figures"] = nlohmann::json::array();
    const pipeline::PipelineEntry* entry = FindPipeline(r.name);
    if (entry != nullptr && entry->figures && r.summary.is_object()) {
      for (const pipeline::Figure& f : entry->figures(pipeline::Field(r.summary, "metrics"))) {
        p["figures"].push_back({{"label", f.label}, {"value", f.value}, {"unit", f.unit}});
      }
    }
    j["pipelines"].push_back(std::move(p));
  }
  return j;
}

std::string Now() {
  return FormatIso8601(std::chrono::time_point_cast<Nanoseconds>(UtcNow()), std::chrono::seconds{0}, 0);
}

}  // namespace

TaskRecord RunBatchTask(const fs::path& plan_file, int index, const std::string& attempt) {
  const BatchPlan plan = ReadPlan(plan_file);
  if (index < 0 || index >= static_cast<int>(plan.tasks.size())) {
    throw InvalidArgumentError("task " + std::to_string(index) + ": the plan " + plan_file.string() + " has tasks 0.." +
                               std::to_string(plan.tasks.size() - 1));
  }
  const BatchTask& task = plan.tasks[static_cast<std::size_t>(index)];
  const fs::path batch_dir = plan_file.parent_path().parent_path();
  const fs::path task_dir = batch_dir / task.folder;
  capture::CreateDirectoryDurably(task_dir);
  const capture::FolderLock lock = capture::FolderLock::Acquire(task_dir, "batch task " + std::to_string(index));

  TaskRecord record;
  record.state = TaskState::kRunning;
  record.index = index;
  record.attempt = attempt;
  record.session = task.session.string();
  record.host = HostName();
  record.pid = static_cast<long>(::getpid());
  record.started_utc = Now();
  WriteJsonDurably(task_dir / kTaskRecordFile, TaskRecordToJson(record));
  std::cout << "task " << index << " (" << attempt << ") on " << record.host << ": " << task.session.string() << "\n"
            << std::flush;

  const auto start = std::chrono::steady_clock::now();
  try {
    const fs::path work = BeginResult(task_dir);
    pipeline::PipelineRequest request = plan.request;
    request.session_dir = task.session;
    request.out_dir = work;
    request.load_truth = rig::LoadSessionTruth;  // evaluation; null for real sessions
    const pipeline::ProcessResult processed = pipeline::ProcessSession(request, [](const pipeline::PipelineReport& r) {
      std::cout << "  " << r.name << ": "
                << (!r.error.empty() ? r.error : (r.summary.is_object() ? r.summary.value("headline", "done") : "done"))
                << "\n"
                << std::flush;
    });
    WriteJsonDurably(work / kResultRecordFile, ResultRecord(processed, record, work));
    PublishResult(task_dir);
    if (processed.failed.empty()) {
      record.state = TaskState::kDone;
    } else {
      record.state = TaskState::kFailed;
      std::string names;
      for (const std::string& n : processed.failed) names += (names.empty() ? "" : ", ") + n;
      record.message = "pipeline(s) " + names + " failed (the report says why; the others' results are published)";
    }
  } catch (const std::exception& e) {
    record.state = TaskState::kFailed;
    record.message = e.what();
  }
  record.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  record.ended_utc = Now();
  WriteJsonDurably(task_dir / kTaskRecordFile, TaskRecordToJson(record));
  std::cout << "task " << index << " " << TaskStateName(record.state) << " in " << record.seconds << " s"
            << (record.message.empty() ? "" : ": " + record.message) << "\n"
            << std::flush;
  return record;
}

}  // namespace relume::batch
