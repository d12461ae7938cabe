// One task of a batch: one session through ProcessSession, into the session's own folder of the
// batch (<out>/sessions/<name>-<hash>/, plan.h), run by a worker process (`relume batch-task`).
//
// What a task leaves, and why a killed task leaves nothing a rerun would reuse:
//   task.json          the task's record: running (written first), then done or failed with why
//   result.partial/    the work folder ProcessSession writes into, with its stage cache
//   result/            the published result: report.html, each pipeline's summary.json and
//                      result.json (the row the index shows)
// A task moves result/ back to result.partial/ before it starts (BeginResult), runs, writes
// result.json and renames result.partial/ to result/ (PublishResult): one rename, after every
// file in it is durable. A task killed at any point leaves at most result.partial/, which no
// index reads and the next run continues in: its completed stages are reused (the stage cache
// renames each stage into place only once it is complete, stage_cache.h) and the rest is
// recomputed. result.json is removed from result.partial/ when work starts, so a work folder
// never holds a row of an earlier run.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace relume::batch {

inline constexpr const char* kResultFolder = "result";
inline constexpr const char* kWorkFolder = "result.partial";
inline constexpr const char* kTaskRecordFile = "task.json";
inline constexpr const char* kResultRecordFile = "result.json";

enum class TaskState { kNotRun, kQueued, kRunning, kDone, kFailed };
const char* TaskStateName(TaskState state);
TaskState TaskStateFromName(const std::string& name);  // kNotRun for an unknown name

// task.json.
struct TaskRecord {
  TaskState state = TaskState::kNotRun;
  int index = -1;
  std::string attempt;  // "slurm-<job id>" or "local-<time>": which run wrote this record
  std::string session;
  std::string host;
  long pid = 0;
  std::string started_utc;
  std::string ended_utc;
  double seconds = 0.0;
  std::string message;  // why it failed
};
nlohmann::json TaskRecordToJson(const TaskRecord& record);
TaskRecord TaskRecordFromJson(const nlohmann::json& j);
// The record in task_dir, or a kNotRun record when there is none (or it cannot be read).
TaskRecord ReadTaskRecord(const std::filesystem::path& task_dir);

// Makes task_dir/result.partial the work folder: a published result/ is moved there (it is no
// longer published while the task runs), a work folder left by a stopped run is kept; an old
// result.json in it is removed. Returns the work folder's path (it may not exist yet).
std::filesystem::path BeginResult(const std::filesystem::path& task_dir);
// Renames task_dir/result.partial to task_dir/result and makes the rename durable. IoError when
// the work folder is missing or the rename fails.
std::filesystem::path PublishResult(const std::filesystem::path& task_dir);

// Runs task `index` of the plan in `plan_file` as attempt `attempt`: locks the task's folder
// (capture/folder_lock.h), records it as running, processes the session into the work folder,
// writes result.json and publishes, then records done, or failed with the reason (a pipeline
// that failed, or an error that stopped the session). Progress goes to standard output (the
// task's log). Returns the final record; throws only when the plan or the folder cannot be used.
TaskRecord RunBatchTask(const std::filesystem::path& plan_file, int index, const std::string& attempt);

}  // namespace relume::batch
