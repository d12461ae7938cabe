#include "batch/batch_options.h"

#include <cmath>

namespace relume::batch {

const char* BackendName(Backend backend) {
  return backend == Backend::kSlurm ? "slurm" : "local";
}

bool IsDefaultRequest(const pipeline::PipelineRequest& request) {
  const pipeline::PipelineRequest none;
  return request.pipeline.empty() && !request.source && !request.target && !request.mesh && !request.target_light &&
         request.settings.empty() && request.explain == none.explain && request.reuse == none.reuse;
}

namespace {

bool Fail(std::string* why, const std::string& text) {
  if (why != nullptr) *why = text;
  return false;
}

bool SlurmIsValid(const SlurmOptions& slurm, std::string* why) {
  if (slurm.cpus_per_task < 1) {
    return Fail(why, "cpus_per_task is " + std::to_string(slurm.cpus_per_task) + "; give 1 or more (--cpus-per-task)");
  }
  if (slurm.memory_per_task_mb < 0) {
    return Fail(why, "memory_per_task_mb is " + std::to_string(slurm.memory_per_task_mb) +
                         "; give 0 (the partition's default) or more (--mem-per-task)");
  }
  if (slurm.max_running_tasks < 0) {
    return Fail(why, "max_running_tasks is " + std::to_string(slurm.max_running_tasks) +
                         "; give 0 (no limit) or more (--max-running)");
  }
  if (!(slurm.poll_interval_s > 0.0) || !std::isfinite(slurm.poll_interval_s)) {
    return Fail(why, "poll_interval_s must be a positive number of seconds (--poll)");
  }
  if (slurm.time_limit.find_first_not_of("0123456789:-") != std::string::npos) {
    return Fail(why, "time_limit '" + slurm.time_limit +
                         "' is not a Slurm time (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS)");
  }
  for (const std::string& arg : slurm.extra_args) {
    if (arg.rfind("--array", 0) == 0 || arg.rfind("--output", 0) == 0 || arg.rfind("--parsable", 0) == 0) {
      return Fail(why, "the sbatch argument '" + arg + "' is relume's to set (it makes the array, logs and job id)");
    }
  }
  for (const std::string* program : {&slurm.sbatch, &slurm.squeue, &slurm.sacct}) {
    if (program->empty()) return Fail(why, "a Slurm client program name is empty");
  }
  return true;
}

}  // namespace

bool BatchOptions::IsValid(std::string* why) const {
  if (out_dir.empty()) return Fail(why, "give the batch's output folder (--out DIR)");
  if (task_command.empty() || task_command.front().empty()) {
    return Fail(why, "task_command is empty: give the program that runs one task (relume batch-task)");
  }
  if (only_failed) {
    if (!sessions.empty()) {
      return Fail(why, "--only-failed reruns the failed tasks of the batch in " + out_dir.string() +
                           " with its own sessions; give no sessions (or start a new batch without --only-failed)");
    }
    if (!IsDefaultRequest(request)) {
      return Fail(why,
                  "--only-failed reruns the failed tasks with the batch's own pipeline options; give none "
                  "(or start a new batch with the options you want)");
    }
  } else if (sessions.empty()) {
    return Fail(why, "no sessions: give session folders, a glob ('field/*/session') or --sessions-from LIST");
  }
  if (!request.session_dir.empty() || !request.out_dir.empty()) {
    return Fail(why, "request.session_dir and request.out_dir are set per task; leave them empty");
  }
  if (request.explain) return Fail(why, "--explain plans one session; run `relume process --explain` on it instead");
  if (backend == Backend::kLocal && local_workers < 1) {
    return Fail(why, "--local " + std::to_string(local_workers) + ": give 1 or more worker processes");
  }
  if (backend == Backend::kSlurm && !SlurmIsValid(slurm, why)) return false;
  return true;
}

}  // namespace relume::batch
