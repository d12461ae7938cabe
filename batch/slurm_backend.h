// The Slurm backend: one job array per run, one array task per session. The job script runs the
// task command on the node (`relume batch-task PLAN $SLURM_ARRAY_TASK_ID slurm-$SLURM_ARRAY_JOB_ID`)
// with its output in <out>/logs/slurm-<job>_<task>.log; the batch folder must be on a filesystem
// the submit host and the nodes share (docs/batch.md). States are read from squeue (which keeps
// ended tasks for MinJobAge, 300 s by default) and, where accounting is on, from sacct.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "batch/batch_options.h"

namespace relume::batch {

// "0-3,7,9-12%2": the indices in Slurm's --array syntax, ranges collapsed, with the throttle
// when max_running > 0. Indices must be sorted and unique.
std::string ArraySpec(const std::vector<int>& indices, int max_running);

// The job script (bash, #SBATCH lines for the resources of `slurm`).
std::string JobScript(const SlurmOptions& slurm, const std::vector<std::string>& task_command,
                      const std::filesystem::path& plan_file, const std::filesystem::path& logs_dir,
                      const std::string& job_name);

// Submits the script as an array (`sbatch --parsable --array=SPEC SCRIPT`) and returns the job id.
// InvalidArgumentError with sbatch's own words when it refuses (no such partition, ...), or when
// sbatch is not on PATH.
std::string SubmitArray(const SlurmOptions& slurm, const std::filesystem::path& script, const std::string& array_spec);

// Each array task's state as Slurm names it ("PENDING", "RUNNING", "COMPLETED", "CANCELLED",
// "FAILED", "TIMEOUT", "OUT_OF_MEMORY", ...), by task index; tasks Slurm no longer knows are
// missing from the map.
std::map<int, std::string> ArrayTaskStates(const SlurmOptions& slurm, const std::string& job_id);

// True for states in which a task may still run (pending, running, completing, suspended, ...).
bool IsActiveSlurmState(const std::string& state);

}  // namespace relume::batch
