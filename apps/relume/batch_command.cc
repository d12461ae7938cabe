#include "apps/relume/batch_command.h"

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>

#include "apps/relume/pipeline_args.h"
#include "batch/batch.h"
#include "batch/local_backend.h"
#include "batch/plan.h"
#include "core/error.h"
#include "core/parallel.h"

namespace relume::app {

namespace {
namespace fs = std::filesystem;

struct BatchArgs {
  std::vector<std::string> sessions;
  std::string sessions_from;
  std::string out;
  PipelineArgs pipeline;
  int local = -1;  // -1: not given
  std::string local_start = "fork";
  bool slurm = false;
  batch::SlurmOptions slurm_options;
  bool no_wait = false;
  bool only_failed = false;
  bool collect = false;
  bool wait = false;
};

void PrintTaskEnd(const batch::TaskOutcome& t) {
  std::cout << "task " << std::setw(3) << t.index << " " << std::left << std::setw(7) << batch::TaskStateName(t.state)
            << std::right;
  if (t.seconds > 0) std::cout << " " << std::fixed << std::setprecision(1) << t.seconds << " s" << std::defaultfloat;
  // The session's folder and its parent: sessions are often all called "session".
  const fs::path session(t.session);
  std::cout << "  " << (session.parent_path().filename() / session.filename()).string();
  if (t.state == batch::TaskState::kDone) {
    for (const batch::PipelineOutcome& p : t.pipelines) {
      if (p.error.empty() && !p.headline.empty()) std::cout << "\n           " << p.name << ": " << p.headline;
    }
  } else if (!t.message.empty()) {
    std::cout << ": " << t.message;
  }
  if (t.state == batch::TaskState::kFailed && !t.log.empty()) std::cout << "\n           log: " << t.log;
  std::cout << "\n" << std::flush;
}

// The end of every run: the counts, where the index is, the tasks still to do and how.
void PrintSummary(const batch::BatchSummary& summary) {
  std::cout << summary.BriefReport() << "\n";
  const std::vector<int> unfinished = summary.Unfinished();
  for (const batch::TaskOutcome& t : summary.tasks) {
    if (t.state != batch::TaskState::kFailed) continue;
    std::cout << "  failed: task " << t.index << " " << t.session << ": " << t.message
              << (t.log.empty() ? "" : " (log " + (summary.out_dir / t.log).string() + ")") << "\n";
  }
  if (!unfinished.empty()) {
    std::cout << "rerun them alone: relume batch --out " << summary.out_dir.string() << " --only-failed"
              << (summary.backend == "slurm" ? " --slurm" : "") << "\n";
  }
}

std::vector<std::string> TaskCommand() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw IoError("/proc/self/exe", "cannot find the relume program to run tasks with: " + ec.message());
  return {self.string(), "batch-task"};
}

void Run(const BatchArgs& args) {
  if (args.out.empty()) throw InvalidArgumentError("relume batch: give the batch's output folder (--out DIR)");
  if (args.local >= 0 && args.slurm) throw InvalidArgumentError("relume batch: give --local N or --slurm, not both");
  if (args.collect) {
    if (!args.sessions.empty() || !args.sessions_from.empty() || args.only_failed) {
      throw InvalidArgumentError("--collect reads the batch in --out as it stands; give no sessions or --only-failed");
    }
    const batch::BatchSummary summary =
        batch::CollectBatch(args.out, args.slurm_options, args.wait, {.on_started = {}, .on_task_end = PrintTaskEnd});
    PrintSummary(summary);
    if (!summary.Unfinished().empty()) throw Error("some tasks have no complete result (listed above)");
    return;
  }
  batch::BatchOptions options;
  if (!args.only_failed) {
    options.sessions = batch::ExpandSessions(
        args.sessions, args.sessions_from.empty() ? std::nullopt : std::optional<fs::path>(args.sessions_from));
  } else {
    // Unexpanded: --only-failed takes none, and BatchOptions::IsValid says so.
    options.sessions.assign(args.sessions.begin(), args.sessions.end());
    if (!args.sessions_from.empty()) options.sessions.emplace_back(args.sessions_from);
  }
  options.out_dir = args.out;
  options.request = PipelineRequestFromArgs(args.pipeline);
  options.backend = args.slurm ? batch::Backend::kSlurm : batch::Backend::kLocal;
  options.local_workers = args.local >= 0 ? args.local : DefaultThreads();
  options.local_start = args.local_start == "exec" ? batch::LocalStart::kExec : batch::LocalStart::kFork;
  options.slurm = args.slurm_options;
  options.slurm.wait = !args.no_wait;
  options.only_failed = args.only_failed;
  options.task_command = TaskCommand();

  batch::BatchCallbacks callbacks;
  callbacks.on_started = [&](const std::string& attempt, const std::string& job_id, const std::vector<int>& indices) {
    if (job_id.empty()) {
      std::cout << "running " << indices.size() << " task(s) on " << options.local_workers << " local worker(s) ("
                << attempt << ", "
                << (batch::EffectiveLocalStart(options.local_start) == batch::LocalStart::kFork
                        ? "forked from this process"
                        : "each started as relume batch-task")
                << ")\n";
    } else {
      std::cout << "submitted Slurm job " << job_id << ": " << indices.size() << " array task(s); logs in "
                << (fs::absolute(args.out) / "logs").string() << "\n";
    }
    std::cout << std::flush;
  };
  callbacks.on_task_end = PrintTaskEnd;
  const batch::BatchSummary summary = batch::RunBatch(options, callbacks);
  if (summary.run.empty()) std::cout << "nothing to run: every task of the batch has a complete result\n";
  if (!summary.waited) {
    std::cout << "job id: " << summary.job_id << "\nnot waiting; gather the index later with: relume batch --out "
              << summary.out_dir.string() << " --collect [--wait]\n";
    return;
  }
  PrintSummary(summary);
  if (!summary.Unfinished().empty()) {
    throw Error(std::to_string(summary.Unfinished().size()) + " task(s) failed (listed above and in " +
                summary.index_html.string() + ")");
  }
}

}  // namespace

void AddBatchCommand(CLI::App& app) {
  auto args = std::make_shared<BatchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "batch", "Process many sessions with one set of pipeline options, locally or as a Slurm job array");
  cmd->add_option("SESSIONS", args->sessions, "Session folders or globs (quote globs: relume expands them)");
  cmd->add_option("--sessions-from", args->sessions_from, "A file naming session folders or globs, one a line");
  cmd->add_option("--out", args->out, "The batch folder: index, logs, each session's results");
  AddPipelineOptions(*cmd, args->pipeline);
  cmd->add_option("--local", args->local, "Run the tasks here with N worker processes (default: one per CPU)");
  cmd->add_option("--local-start", args->local_start,
                  "How a local worker starts: fork (a copy of this process runs the task; no program start "
                  "per task) or exec (relume batch-task is started for each task)")
      ->check(CLI::IsMember({"fork", "exec"}));
  cmd->add_flag("--slurm", args->slurm, "Submit the tasks as a Slurm job array (sbatch)");
  cmd->add_option("--partition", args->slurm_options.partition, "Slurm partition");
  cmd->add_option("--account", args->slurm_options.account, "Slurm account");
  cmd->add_option("--time", args->slurm_options.time_limit, "Time limit per task (Slurm format: 30, 1:00:00, 1-0)");
  cmd->add_option("--cpus-per-task", args->slurm_options.cpus_per_task, "CPUs per task (Slurm)");
  cmd->add_option("--mem-per-task", args->slurm_options.memory_per_task_mb, "Memory per task in MB (Slurm)");
  cmd->add_option("--max-running", args->slurm_options.max_running_tasks, "At most M tasks at once (Slurm %M)");
  cmd->add_option("--sbatch-arg", args->slurm_options.extra_args, "A further sbatch argument (repeatable)");
  cmd->add_option("--poll", args->slurm_options.poll_interval_s, "Seconds between squeue polls while waiting");
  cmd->add_flag("--no-wait", args->no_wait, "Print the job id and return once submitted");
  cmd->add_flag("--only-failed,--retry", args->only_failed, "Rerun only the tasks without a complete result");
  cmd->add_flag("--collect", args->collect, "Gather the index of the batch in --out as it stands");
  cmd->add_flag("--wait", args->wait, "With --collect: wait until no task is queued or running");
  cmd->callback([args]() { Run(*args); });

  struct TaskArgs {
    std::string plan;
    int index = -1;
    std::string attempt;
  };
  auto task = std::make_shared<TaskArgs>();
  CLI::App* task_cmd =
      app.add_subcommand("batch-task", "Run one task of a batch (what relume batch's workers and job script call)");
  task_cmd->add_option("PLAN", task->plan, "The batch's plan file (DIR/plans/plan-*.json)")->required();
  task_cmd->add_option("INDEX", task->index, "The task's index in the plan")->required();
  task_cmd->add_option("ATTEMPT", task->attempt, "The attempt id (local-..., slurm-JOB)")->required();
  task_cmd->callback([task]() {
    const batch::TaskRecord record = batch::RunBatchTask(task->plan, task->index, task->attempt);
    if (record.state != batch::TaskState::kDone) throw CLI::RuntimeError(1);
  });
}

}  // namespace relume::app
