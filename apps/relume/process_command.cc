#include "apps/relume/process_command.h"

#include <CLI/CLI.hpp>
#include <cctype>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>

#include "apps/relume/pipeline_args.h"
#include "core/error.h"
#include "pipeline/process.h"
#include "rig/session_truth.h"

namespace relume::app {

namespace {

struct ProcessArgs {
  std::string session;
  std::string out;
  PipelineArgs pipeline;
  bool explain = false;
  bool list = false;
  bool verbose = false;
};

// Everything through std::cout (main turns off stdio sync, so mixing printf would reorder lines).
void PrintDecision(const std::string& stage, const std::string& action, const std::string& reason) {
  std::cout << "  " << std::left << std::setw(16) << stage << " " << std::setw(7) << action << " " << reason << "\n";
}

// `--verbose`: every decision (stage cache events too) and every file written.
void PrintSummaryVerbose(const nlohmann::json& summary, const std::string& out_dir) {
  std::cout << "pipeline " << summary["pipeline"].get<std::string>() << " on " << summary["session"].get<std::string>()
            << (summary["explain"].get<bool>() ? " (plan only)" : "") << "\n";
  for (const nlohmann::json& d : summary["decisions"]) PrintDecision(d["stage"], d["action"], d["reason"]);
  if (summary["explain"].get<bool>()) return;
  for (const nlohmann::json& o : summary["outputs"]) {
    std::cout << "  wrote " << out_dir << "/" << o["path"].get<std::string>() << "  (" << o["what"].get<std::string>()
              << ")\n";
  }
  std::cout << "done in " << std::fixed << std::setprecision(2) << summary["seconds"].get<double>() << " s; summary in "
            << out_dir << "/summary.json\n"
            << std::defaultfloat;
}

// The reason with every number replaced by '#': decisions that differ only in their numbers
// ("frame 12: depth changed in 3.1 % of pixels") group together.
std::string NumbersMasked(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const bool digit = std::isdigit(static_cast<unsigned char>(text[i])) != 0;
    if (!digit) {
      out += text[i];
      continue;
    }
    while (i + 1 < text.size() && (std::isdigit(static_cast<unsigned char>(text[i + 1])) != 0 ||
                                   (text[i + 1] == '.' && i + 2 < text.size() &&
                                    std::isdigit(static_cast<unsigned char>(text[i + 2])) != 0))) {
      ++i;
    }
    out += '#';
  }
  return out;
}

// Default: the decisions that shape the result (stage cache events counted, not listed), alike
// decisions as one line with their count, and one closing line per pipeline.
void PrintSummary(const nlohmann::json& summary, const std::string& out_dir) {
  std::cout << summary["pipeline"].get<std::string>() << (summary["explain"].get<bool>() ? " (plan only)" : "") << "\n";
  struct Group {
    std::string stage, action, reason;
    int count = 0;
  };
  std::vector<Group> groups;
  std::map<std::string, std::size_t> index;
  int ran = 0, reused = 0;
  for (const nlohmann::json& d : summary["decisions"]) {
    if (d.value("cache", false)) {
      (d["action"] == "reuse" ? reused : ran) += 1;
      continue;
    }
    const std::string key = d["stage"].get<std::string>() + "\n" + d["action"].get<std::string>() + "\n" +
                            NumbersMasked(d["reason"].get<std::string>());
    const auto [it, inserted] = index.emplace(key, groups.size());
    if (inserted) groups.push_back({d["stage"], d["action"], d["reason"], 0});
    ++groups[it->second].count;
  }
  for (const Group& g : groups) {
    PrintDecision(g.stage, g.action, g.count > 1 ? "(x" + std::to_string(g.count) + ", e.g.) " + g.reason : g.reason);
  }
  if (summary["explain"].get<bool>()) return;
  std::cout << "  " << ran << " stage(s) run, " << reused << " reused; " << summary["outputs"].size()
            << " output(s) in " << out_dir << " (--verbose lists them); " << std::fixed << std::setprecision(1)
            << summary["seconds"].get<double>() << " s\n"
            << std::defaultfloat;
}

void Print(const nlohmann::json& summary, const std::string& out_dir, bool verbose) {
  if (verbose) {
    PrintSummaryVerbose(summary, out_dir);
  } else {
    PrintSummary(summary, out_dir);
  }
}

// The closing lines: each pipeline's headline figures, or why it did not run.
void PrintHeadlines(const std::vector<pipeline::PipelineReport>& reports) {
  std::cout << "summary:\n";
  for (const pipeline::PipelineReport& r : reports) {
    std::string line = !r.error.empty() ? "not run: " + r.error
                       : r.summary.is_object() && r.summary.contains("headline")
                           ? r.summary["headline"].get<std::string>()
                           : std::string("done");
    std::cout << "  " << std::left << std::setw(10) << r.name << " " << line << "\n";
  }
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
    ListPipelines(args.pipeline.pipeline);
    return;
  }
  if (args.session.empty()) throw InvalidArgumentError("relume process: give the session folder");
  pipeline::PipelineRequest request = PipelineRequestFromArgs(args.pipeline);
  const bool all = request.pipeline.empty() || request.pipeline == "all";
  request.session_dir = args.session;
  request.out_dir = args.out.empty()
                        ? std::filesystem::path(args.session) / "processed" / (all ? std::string() : request.pipeline)
                        : std::filesystem::path(args.out);
  request.explain = args.explain;
  request.load_truth = rig::LoadSessionTruth;  // evaluation only; null for real sessions
  const pipeline::ProcessResult result = pipeline::ProcessSession(request, [&](const pipeline::PipelineReport& r) {
    if (!r.summary.is_null()) {
      Print(r.summary, r.out_dir.string(), args.verbose);
    } else if (r.error.rfind("failed: ", 0) == 0) {
      std::cout << r.name << " FAILED: " << r.error.substr(8) << "\n";
    } else {
      std::cout << r.name << " skipped: " << r.error << "\n";
    }
  });
  if (!args.explain) {
    PrintHeadlines(result.reports);
    std::cout << "report: " << result.report.string() << "\n";
  }
  if (!result.failed.empty()) {
    std::string names;
    for (const std::string& n : result.failed) names += (names.empty() ? "" : ", ") + n;
    throw Error("pipeline(s) " + names + " failed (see above); the others' results are kept");
  }
}

}  // namespace

void AddProcessCommand(CLI::App& app) {
  auto args = std::make_shared<ProcessArgs>();
  CLI::App* cmd =
      app.add_subcommand("process", "Reprocess a recorded session through a pipeline (reuses unchanged stages)");
  cmd->add_option("SESSION", args->session, "Session folder (from relume capture)");
  cmd->add_option("--out", args->out, "Output folder (default SESSION/processed[/PIPELINE])");
  AddPipelineOptions(*cmd, args->pipeline);
  cmd->add_flag("--explain", args->explain, "Print the plan and its reasons; run nothing expensive");
  cmd->add_flag("--verbose", args->verbose, "Print every decision (stage reuse too) and every file written");
  cmd->add_flag("--list", args->list, "List the pipelines of this build (with --pipeline: its knobs and defaults)");
  cmd->callback([args]() { Run(*args); });
}

}  // namespace relume::app
