#include "apps/relume/process_command.h"

#include <CLI/CLI.hpp>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>

#include "capture/folder_lock.h"
#include "core/error.h"
#include "pipeline/pipeline.h"
#include "pipeline/report.h"

namespace relume::app {

namespace {

struct ProcessArgs {
  std::string session;
  std::string out;
  std::string pipeline;
  std::string source;
  std::string target;
  std::string mesh;
  std::string target_light;
  std::vector<std::string> settings;
  bool explain = false;
  bool force = false;
  bool list = false;
};

// Everything through std::cout (main turns off stdio sync, so mixing printf would reorder lines).
void PrintSummary(const nlohmann::json& summary, const std::string& out_dir) {
  std::cout << "pipeline " << summary["pipeline"].get<std::string>() << " on " << summary["session"].get<std::string>()
            << (summary["explain"].get<bool>() ? " (plan only)" : "") << "\n";
  for (const nlohmann::json& d : summary["decisions"]) {
    std::cout << "  " << std::left << std::setw(16) << d["stage"].get<std::string>() << " " << std::setw(7)
              << d["action"].get<std::string>() << " " << d["reason"].get<std::string>() << "\n";
  }
  if (summary["explain"].get<bool>()) return;
  for (const nlohmann::json& o : summary["outputs"]) {
    std::cout << "  wrote " << out_dir << "/" << o["path"].get<std::string>() << "  (" << o["what"].get<std::string>()
              << ")\n";
  }
  std::cout << "done in " << std::fixed << std::setprecision(2) << summary["seconds"].get<double>() << " s; summary in "
            << out_dir << "/summary.json\n"
            << std::defaultfloat;
}

// The pipelines; with a name, that pipeline's knobs (--set) with their defaults.
void ListPipelines(const std::string& name) {
  bool found = false;
  for (const pipeline::PipelineEntry& entry : pipeline::Pipelines()) {
    if (!name.empty() && name != "all" && entry.name != name) continue;
    found = true;
    std::cout << std::left << std::setw(12) << entry.name << " " << entry.description << "\n";
    if (name.empty() || name == "all") continue;
    std::cout << "knobs (--set KEY=VALUE):\n";
    for (const pipeline::KnobInfo& k : entry.knobs) {
      std::string stages;
      for (const std::string& s : k.stages) stages += (stages.empty() ? "" : ",") + s;
      std::cout << "  " << std::setw(36) << (k.name + "=" + k.default_value.dump()) << " " << k.help << " [" << stages
                << "]\n";
    }
  }
  if (!found) throw InvalidArgumentError("--list --pipeline " + name + ": no such pipeline (`relume process --list`)");
}

void Run(const ProcessArgs& args) {
  if (args.list) {
    ListPipelines(args.pipeline);
    return;
  }
  if (args.session.empty()) throw InvalidArgumentError("relume process: give the session folder");
  const bool all = args.pipeline.empty() || args.pipeline == "all";
  pipeline::PipelineRequest request;
  request.session_dir = args.session;
  request.out_dir = args.out.empty()
                        ? std::filesystem::path(args.session) / "processed" / (all ? std::string() : args.pipeline)
                        : std::filesystem::path(args.out);
  request.pipeline = args.pipeline;
  if (!args.source.empty()) request.source = args.source;
  if (!args.target.empty()) request.target = args.target;
  if (!args.mesh.empty()) request.mesh = args.mesh;
  if (!args.target_light.empty()) request.target_light = args.target_light;
  for (const std::string& kv : args.settings) {
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InvalidArgumentError("--set " + kv + ": expected KEY=VALUE (e.g. --set sh_order=1)");
    }
    request.settings[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  request.explain = args.explain;
  request.reuse = !args.force;
  pipeline::CheckSettings(request.settings, all ? "all" : args.pipeline);
  pipeline::PrepareOutputFolder(request.out_dir);
  const capture::FolderLock lock = capture::FolderLock::Acquire(request.out_dir, "process");

  std::vector<pipeline::PipelineReport> reports;
  if (!all) {
    nlohmann::json summary = pipeline::RunPipeline(request);
    PrintSummary(summary, request.out_dir.string());
    reports.push_back({request.pipeline, request.out_dir, std::move(summary), ""});
  } else {
    // Every pipeline of this build, each into its own folder; one that cannot run on this
    // session says why and the others go on.
    std::string failed;
    for (const pipeline::PipelineEntry& entry : pipeline::Pipelines()) {
      pipeline::PipelineRequest one = request;
      one.pipeline = entry.name;
      one.out_dir = request.out_dir / entry.name;
      try {
        nlohmann::json summary = pipeline::RunPipeline(one);
        PrintSummary(summary, one.out_dir.string());
        reports.push_back({entry.name, one.out_dir, std::move(summary), ""});
      } catch (const InvalidArgumentError& e) {
        std::cout << "pipeline " << entry.name << " skipped: " << e.what() << "\n";
        reports.push_back({entry.name, one.out_dir, nullptr, e.what()});
      } catch (const Error& e) {
        // Reported, and the run ends with an error after the report is written.
        std::cout << "pipeline " << entry.name << " FAILED: " << e.what() << "\n";
        reports.push_back({entry.name, one.out_dir, nullptr, std::string("failed: ") + e.what()});
        failed += (failed.empty() ? "" : ", ") + entry.name;
      }
    }
    if (!args.explain) {
      const std::filesystem::path page =
          pipeline::WriteReport(capture::SessionReader(request.session_dir), request.out_dir, reports);
      std::cout << "report: " << page.string() << "\n";
    }
    if (!failed.empty()) throw Error("pipeline(s) " + failed + " failed (see above); the others' results are kept");
    return;
  }
  if (args.explain) return;
  const std::filesystem::path page =
      pipeline::WriteReport(capture::SessionReader(request.session_dir), request.out_dir, reports);
  std::cout << "report: " << page.string() << "\n";
}

}  // namespace

void AddProcessCommand(CLI::App& app) {
  auto args = std::make_shared<ProcessArgs>();
  CLI::App* cmd =
      app.add_subcommand("process", "Reprocess a recorded session through a pipeline (reuses unchanged stages)");
  cmd->add_option("SESSION", args->session, "Session folder (from relume capture)");
  cmd->add_option("--pipeline", args->pipeline, "Pipeline to run (--list names them; default: all of them)");
  cmd->add_option("--out", args->out, "Output folder (default SESSION/processed[/PIPELINE])");
  cmd->add_option("--source", args->source, "Source frames: id, bracket:N, DEVICE:STREAM or all");
  cmd->add_option("--target", args->target, "Target frames: id, bracket:N, DEVICE:STREAM or all");
  cmd->add_option("--mesh", args->mesh, "Scene geometry when the session did not record it");
  cmd->add_option("--target-light", args->target_light, "Destination lighting: frame selector, SH .json or env map");
  cmd->add_option("--set", args->settings, "A pipeline knob, KEY=VALUE (repeatable)");
  cmd->add_flag("--explain", args->explain, "Print the plan and its reasons; run nothing expensive");
  cmd->add_flag("--force", args->force, "Recompute every stage, even unchanged ones");
  cmd->add_flag("--list", args->list, "List the pipelines of this build (with --pipeline: its knobs and defaults)");
  cmd->callback([args]() { Run(*args); });
}

}  // namespace relume::app
