// The batch's index: every task's outcome in one CSV (a row per session: state, time, each
// pipeline's key figures as columns) and one static page, index.html (the counts, a row per
// session with each pipeline's headline and a link to its report, and the failed tasks with
// their reason, log and how to rerun them). Both are written durably (temporary name, rename),
// so a reader never sees half an index.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "batch/task.h"

namespace relume::batch {

struct FigureValue {
  std::string label;
  std::string value;
  std::string unit;
};

struct PipelineOutcome {
  std::string name;
  std::string headline;  // empty when it did not run
  std::string error;     // why it did not run ("failed: ..." when it failed)
  std::vector<FigureValue> figures;
};

struct TaskOutcome {
  int index = 0;
  std::string session;  // absolute path
  std::string folder;   // relative to the batch folder
  TaskState state = TaskState::kNotRun;
  std::string message;        // why it failed (the task's own words, or what the backend saw)
  std::string attempt;        // the attempt that ran it last
  std::string backend_state;  // what the backend saw at its end ("COMPLETED", "CANCELLED", "signal 9")
  std::string log;            // relative to the batch folder; empty when it never ran
  std::string report;         // relative to the batch folder; empty when no result is published
  double seconds = 0.0;
  std::vector<PipelineOutcome> pipelines;
};

struct BatchSummary {
  std::filesystem::path out_dir;
  std::string backend;   // "local" or "slurm"
  std::string attempt;   // this run's attempt id (empty when only collected)
  std::string job_id;    // the Slurm job id of this run, when it submitted one
  bool waited = true;    // false: submitted and returned; states are as they were then
  std::vector<int> run;  // the task indices this run started or submitted
  std::vector<TaskOutcome> tasks;
  double wall_seconds = 0.0;
  std::filesystem::path index_csv;
  std::filesystem::path index_html;

  int Count(TaskState state) const;
  // Indices of tasks without a complete result (failed or not run); queued and running ones are
  // not counted.
  std::vector<int> Unfinished() const;
  bool AllDone() const { return Count(TaskState::kDone) == static_cast<int>(tasks.size()); }
  // "10 sessions: 9 done, 1 failed (task 5); index: DIR/index.html".
  std::string BriefReport() const;
};

std::string IndexCsv(const BatchSummary& summary);
std::string IndexHtml(const BatchSummary& summary);
// Writes <out>/index.csv and <out>/index.html and sets summary.index_csv and index_html.
void WriteIndex(BatchSummary& summary);

}  // namespace relume::batch
