// `relume batch`: many sessions through ProcessSession with one set of pipeline options, one
// task per session, on this machine (N worker processes) or on a Slurm cluster (a job array),
// gathered into one index (index.csv, index.html: index.h). docs/batch.md.
//
// The batch folder (--out):
//   batch.json            which plan is current and, per task, its last attempt, log and end
//   plans/plan-<h>.json   the plans (plan.h); never changed once written
//   sessions/<name>-<h>/  each session's task folder: task.json, result/ (task.h)
//   logs/                 each attempt's log per task (local-<time>_<i>.log, slurm-<job>_<i>.log)
//   slurm/                the job scripts submitted
//   index.csv, index.html
//
// Rerunning a batch runs every task again: the stage cache of each session's folder reuses every
// stage whose inputs, settings and code are unchanged, so a rerun of a finished batch only checks
// (docs/benchmarks.md measures it). `only_failed` reruns the tasks without a complete result.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include "batch/batch_options.h"
#include "batch/index.h"

namespace relume::batch {

struct BatchCallbacks {
  // After sbatch accepted the array (Slurm) or before the first worker starts (local).
  std::function<void(const std::string& attempt, const std::string& job_id, const std::vector<int>& indices)>
      on_started;
  // As each task ends (its final state, message and log).
  std::function<void(const TaskOutcome&)> on_task_end;
};

inline constexpr const char* kStateFile = "batch.json";

// Plans (or, with only_failed, reloads) the batch, runs or submits its tasks, waits for them
// unless Slurm's `wait` is false, and writes the index. Errors a user can cause (no sessions, a
// folder that is not a session, sbatch missing or refusing, an output folder of someone else's,
// a job of this batch still running) are thrown before any task starts. Failed tasks are not
// errors: they are in the summary (BatchSummary::Unfinished).
BatchSummary RunBatch(const BatchOptions& options, const BatchCallbacks& callbacks = {});

// The batch in out_dir as it stands: asks Slurm about tasks of its last job that had not ended,
// with `wait` until none is queued or running, and writes the index. `slurm` supplies the client
// programs and the poll interval.
BatchSummary CollectBatch(const std::filesystem::path& out_dir, const SlurmOptions& slurm, bool wait,
                          const BatchCallbacks& callbacks = {});

}  // namespace relume::batch
