// What `relume batch` runs and where: the sessions, one set of pipeline options for all of them,
// the output folder, and the backend that runs one task per session (N local worker processes,
// or a Slurm job array). Checked up front (IsValid) before anything is written or submitted.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"

namespace relume::batch {

enum class Backend { kLocal, kSlurm };

// How the local backend starts a worker for a task (local_backend.h): a fork of this process that
// runs the task (no program start per task), or the task command.
enum class LocalStart { kFork, kExec };

// Resources and behaviour of the Slurm job array (docs/batch.md). Empty strings and zeros leave
// the cluster's defaults in place.
struct SlurmOptions {
  std::string partition;                // --partition
  std::string account;                  // --account
  std::string time_limit;               // --time per task, in Slurm's formats ("30", "1:00:00", "1-0")
  int cpus_per_task = 1;                // --cpus-per-task
  int memory_per_task_mb = 0;           // --mem (0: the partition's default)
  int max_running_tasks = 0;            // the array's %M throttle (0: no limit)
  std::vector<std::string> extra_args;  // further sbatch arguments, verbatim ("--qos=long")
  bool wait = true;                     // false: return once the job is submitted, with its id
  double poll_interval_s = 10.0;        // how often squeue is asked while waiting
  std::string sbatch = "sbatch";        // the client programs, found on PATH when not absolute
  std::string squeue = "squeue";
  std::string sacct = "sacct";
};

struct BatchOptions {
  // Session folders (ExpandSessions resolves a list file and globs into these).
  std::vector<std::filesystem::path> sessions;
  // Where the index, logs and each session's results go (sessions/<name>-<hash>/).
  std::filesystem::path out_dir;
  // The pipeline options every task uses; session_dir and out_dir are set per task.
  pipeline::PipelineRequest request;
  Backend backend = Backend::kLocal;
  int local_workers = 1;  // worker processes of the local backend
  LocalStart local_start = LocalStart::kFork;
  SlurmOptions slurm;
  // Rerun only the tasks of the batch already in out_dir that have no complete result (failed,
  // killed, never run), with that batch's sessions and pipeline options: `sessions` must be
  // empty and `request` left at its defaults.
  bool only_failed = false;
  // The program and leading arguments that run one task ({"/usr/bin/relume", "batch-task"}); the
  // backends append the plan file, the task index and the attempt id.
  std::vector<std::string> task_command;

  bool IsValid(std::string* why) const;
};

const char* BackendName(Backend backend);

// True when every field of `request` that a user can set is at its default.
bool IsDefaultRequest(const pipeline::PipelineRequest& request);

}  // namespace relume::batch
