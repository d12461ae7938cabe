#include "apps/relume/bench_command.h"

#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <memory>
#include <utility>

#include "apps/relume/bench/bench.h"
#include "core/error.h"

namespace relume::app {
namespace {

struct BenchArgs {
  std::string stage = "all";
  bool quick = false;
  std::string out = "bench";
};

using StageFn = void (*)(bool, std::vector<bench::Row>&);
const std::vector<std::pair<std::string, StageFn>>& Stages() {
  static const std::vector<std::pair<std::string, StageFn>> stages = {{"hdr", bench::BenchHdr},
                                                                      {"sun", bench::BenchSun},
                                                                      {"sh", bench::BenchSh},
                                                                      {"irm", bench::BenchIrm},
                                                                      {"radiosity", bench::BenchRadiosity},
                                                                      {"planner", bench::BenchPlanner}};
  return stages;
}

std::string StageNames() {
  std::string names;
  for (const auto& [name, fn] : Stages()) names += name + ", ";
  return names + "all";
}

void Run(const BenchArgs& args) {
  bool known = args.stage == "all";
  for (const auto& [name, fn] : Stages()) known = known || name == args.stage;
  if (!known) throw InvalidArgumentError("--stage " + args.stage + ": the stages with a benchmark are " + StageNames());
  std::vector<bench::Row> rows;
  for (const auto& [name, fn] : Stages()) {
    if (args.stage != "all" && args.stage != name) continue;
    std::cerr << "bench: " << name << (args.quick ? " (quick)" : "") << "\n";
    fn(args.quick, rows);
  }
  const std::string md = bench::WriteOutputs(args.out, rows);
  std::cout << md << "wrote " << args.out << "/bench.csv, bench.md and one SVG plot per stage\n";
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand("bench", "Run time against error, with the independent peers beside relume");
  cmd->add_option("--stage", args->stage, StageNames())->capture_default_str();
  cmd->add_flag("--quick", args->quick, "Small inputs: a minute or two, for CI");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  cmd->callback([args]() { Run(*args); });
}

}  // namespace relume::app
