#include "apps/relume/bench_command.h"

#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <memory>
#include <utility>

#include "apps/relume/bench/bench.h"
#include "bench/suite.h"
#include "core/error.h"

namespace relume::app {
namespace {

struct BenchArgs {
  std::string stage = "all";
  bool quick = false;
  std::string out = "bench";
  std::string suite;  // "random": the random-scene suites (bench/suite.h) instead of the knob sweeps
  relume::bench::SuiteOptions suite_options;
};

using StageFn = void (*)(bool, std::vector<bench::Row>&);
const std::vector<std::pair<std::string, StageFn>>& Stages() {
  static const std::vector<std::pair<std::string, StageFn>> stages = {
      {"hdr", bench::BenchHdr},        {"hdr-files", bench::BenchHdrFiles},
      {"sun", bench::BenchSun},        {"sh", bench::BenchSh},
      {"irm", bench::BenchIrm},        {"radiosity", bench::BenchRadiosity},
      {"planner", bench::BenchPlanner}};
  return stages;
}

std::string StageNames() {
  std::string names;
  for (const auto& [name, fn] : Stages()) names += name + ", ";
  return names + "all";
}

void RunRandomSuites(const BenchArgs& args) {
  const std::vector<relume::bench::SuiteResult> results =
      relume::bench::RunSuites(args.stage, args.suite_options, [&](const std::string& name) {
        std::cerr << "bench: suite " << name << ", " << args.suite_options.SceneCount() << " scene(s)"
                  << (args.suite_options.quick ? " (quick)" : "") << "\n";
      });
  const std::string md = relume::bench::WriteSuiteOutputs(args.out, results, args.suite_options);
  std::cout << md << "wrote " << args.out << "/suite.md, suite.csv (one row per scene) and suite.json\n";
}

void Run(const BenchArgs& args) {
  if (!args.suite.empty()) {
    if (args.suite != "random") throw InvalidArgumentError("--suite " + args.suite + ": the only suite is random");
    RunRandomSuites(args);
    return;
  }
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
  cmd->add_option("--suite", args->suite,
                  "random: seeded random scenes per stage, median / p90 / worst error beside the stage's floor "
                  "(bench/suite.h)");
  cmd->add_option("--scenes", args->suite_options.scenes, "Scenes per random suite")->capture_default_str();
  cmd->add_option("--seed", args->suite_options.seed, "Seed of the random suites")->capture_default_str();
  cmd->add_option("--scene-seed", args->suite_options.scene_seed,
                  "Run only the scene of this seed (a row of suite.csv), instead of --scenes/--seed");
  cmd->add_option("--truth-rays-factor", args->suite_options.truth_rays_factor,
                  "Multiplies the bounce-light rays of the IRM bounces suite's renders (less render noise in the "
                  "photographs, the truth and the floor)")
      ->capture_default_str();
  cmd->callback([args]() {
    args->suite_options.quick = args->quick;
    Run(*args);
  });
}

}  // namespace relume::app
