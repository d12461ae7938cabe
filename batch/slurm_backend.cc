#include "batch/slurm_backend.h"

#include <charconv>
#include <sstream>

#include "batch/subprocess.h"
#include "core/error.h"

namespace relume::batch {
namespace fs = std::filesystem;

namespace {

constexpr const char* kMissingSlurm =
    "install Slurm's client commands (Debian: slurm-client), run on a host of the cluster, or use --local N";

// A word for bash: single-quoted, with each ' written as '\''.
std::string ShellQuote(const std::string& text) {
  std::string out = "'";
  for (const char c : text) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

bool ParseInt(const std::string& text, int* value) {
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), *value);
  return ec == std::errc() && ptr == text.data() + text.size();
}

// "3", "3-7" or "3-7:2" (Slurm's range syntax inside brackets) into `out`.
void ExpandRange(const std::string& range, std::vector<int>& out) {
  const std::string body = range.substr(0, range.find('%'));
  std::istringstream parts(body);
  std::string part;
  while (std::getline(parts, part, ',')) {
    const std::size_t dash = part.find('-');
    int first = 0, last = 0, step = 1;
    if (dash == std::string::npos) {
      if (ParseInt(part, &first)) out.push_back(first);
      continue;
    }
    std::string tail = part.substr(dash + 1);
    if (const std::size_t colon = tail.find(':'); colon != std::string::npos) {
      if (!ParseInt(tail.substr(colon + 1), &step) || step < 1) step = 1;
      tail = tail.substr(0, colon);
    }
    if (!ParseInt(part.substr(0, dash), &first) || !ParseInt(tail, &last)) continue;
    for (int i = first; i <= last; i += step) out.push_back(i);
  }
}

// "1234_5|RUNNING" or "1234_[6-9%2]|PENDING" lines (squeue) and "1234_5|CANCELLED by 0" (sacct).
void ParseStateLines(const std::string& output, const std::string& job_id, std::map<int, std::string>& states,
                     bool overwrite) {
  std::istringstream lines(output);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t bar = line.find('|');
    if (bar == std::string::npos) continue;
    const std::string id = line.substr(0, bar);
    std::string state = line.substr(bar + 1);
    state = state.substr(0, state.find_first_of(" |\r"));
    if (id.rfind(job_id + "_", 0) != 0 || state.empty()) continue;
    std::string task = id.substr(job_id.size() + 1);
    if (task.find('.') != std::string::npos) continue;  // a step (sacct without -X)
    std::vector<int> indices;
    if (!task.empty() && task.front() == '[') {
      ExpandRange(task.substr(1, task.find(']') - 1), indices);
    } else {
      ExpandRange(task, indices);
    }
    for (const int i : indices) {
      if (overwrite || !states.contains(i)) states[i] = state;
    }
  }
}

}  // namespace

std::string ArraySpec(const std::vector<int>& indices, int max_running) {
  std::string spec;
  for (std::size_t i = 0; i < indices.size();) {
    std::size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    if (!spec.empty()) spec += ',';
    spec += std::to_string(indices[i]);
    if (j > i) {
      spec += '-';
      spec += std::to_string(indices[j]);
    }
    i = j + 1;
  }
  if (max_running > 0) {
    spec += '%';
    spec += std::to_string(max_running);
  }
  return spec;
}

std::string JobScript(const SlurmOptions& slurm, const std::vector<std::string>& task_command,
                      const fs::path& plan_file, const fs::path& logs_dir, const std::string& job_name) {
  std::string s = "#!/bin/bash\n# Written by relume batch: one array task per session (docs/batch.md).\n";
  s += "#SBATCH --job-name=" + job_name + "\n";
  s += "#SBATCH --output=" + (logs_dir / "slurm-%A_%a.log").string() + "\n";
  s += "#SBATCH --cpus-per-task=" + std::to_string(slurm.cpus_per_task) + "\n";
  s += "#SBATCH --ntasks=1\n";
  if (slurm.memory_per_task_mb > 0) s += "#SBATCH --mem=" + std::to_string(slurm.memory_per_task_mb) + "M\n";
  if (!slurm.time_limit.empty()) s += "#SBATCH --time=" + slurm.time_limit + "\n";
  if (!slurm.partition.empty()) s += "#SBATCH --partition=" + slurm.partition + "\n";
  if (!slurm.account.empty()) s += "#SBATCH --account=" + slurm.account + "\n";
  s += "set -u\n";
  s += "echo \"relume batch: array task ${SLURM_ARRAY_TASK_ID} of job ${SLURM_ARRAY_JOB_ID} on $(hostname)\"\n";
  s += "exec";
  for (const std::string& word : task_command) {
    s += ' ';
    s += ShellQuote(word);
  }
  s += ' ';
  s += ShellQuote(plan_file.string());
  s += " \"${SLURM_ARRAY_TASK_ID}\" \"slurm-${SLURM_ARRAY_JOB_ID}\"\n";
  return s;
}

std::string SubmitArray(const SlurmOptions& slurm, const fs::path& script, const std::string& array_spec) {
  std::vector<std::string> argv = {slurm.sbatch, "--parsable", "--array=" + array_spec};
  argv.insert(argv.end(), slurm.extra_args.begin(), slurm.extra_args.end());
  argv.push_back(script.string());
  const ProgramResult submitted = RunProgram(argv, kMissingSlurm);
  // --parsable prints "<job id>" or "<job id>;<cluster>" as its last line; warnings may precede it.
  std::string job_id;
  std::istringstream lines(submitted.output);
  std::string line;
  while (std::getline(lines, line)) {
    const std::string id = line.substr(0, line.find(';'));
    int value = 0;
    if (!id.empty() && ParseInt(id, &value)) job_id = id;
  }
  if (submitted.exit_code != 0 || job_id.empty()) {
    throw InvalidArgumentError("sbatch refused the job array (exit code " + std::to_string(submitted.exit_code) +
                               "): " + submitted.output + "(the job script is " + script.string() +
                               "; check --partition, --time, --mem-per-task and --sbatch-arg)");
  }
  return job_id;
}

std::map<int, std::string> ArrayTaskStates(const SlurmOptions& slurm, const std::string& job_id) {
  std::map<int, std::string> states;
  const ProgramResult queue = RunProgram(
      {slurm.squeue, "--jobs=" + job_id, "--array", "--states=all", "--noheader", "--format=%i|%T"}, kMissingSlurm);
  // squeue fails ("Invalid job id specified") once the controller has forgotten the job.
  if (queue.exit_code == 0) ParseStateLines(queue.output, job_id, states, true);
  // Accounting knows ended tasks for longer; a cluster without it answers with an error.
  try {
    const ProgramResult accounting = RunProgram(
        {slurm.sacct, "--jobs=" + job_id, "--allocations", "--noheader", "--parsable2", "--format=JobID,State"},
        kMissingSlurm);
    if (accounting.exit_code == 0) ParseStateLines(accounting.output, job_id, states, false);
  } catch (const InvalidArgumentError&) {
    // no sacct on PATH: squeue's answer is all there is
  }
  return states;
}

bool IsActiveSlurmState(const std::string& state) {
  static const char* const kActive[] = {"PENDING",     "RUNNING",  "CONFIGURING",  "COMPLETING", "SUSPENDED",
                                        "REQUEUED",    "RESIZING", "SIGNALING",    "STAGE_OUT",  "REQUEUE_HOLD",
                                        "REQUEUE_FED", "STOPPED",  "RESV_DEL_HOLD"};
  for (const char* s : kActive) {
    if (state == s) return true;
  }
  return false;
}

}  // namespace relume::batch
