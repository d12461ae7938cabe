// Random-scene suites: accuracy as a property of a method, not of one scene (issue 20).
//
// A suite draws N scenes from a seeded generator (objects, albedos, lights, cameras, sensor
// responses, noise), runs one stage of relume on each and compares the result with the
// scene's truth. Beside the method it runs the stage's *floor*: the same stage given the truth
// it would otherwise estimate (true normals, true visibility, true response, ...), so the gap
// between the method and its model is visible. It reports median, p90 and worst of both.
//
// Scene i of a suite uses SceneSeed(options.seed, i); its seed is in suite.csv, and
// `relume bench --suite random --stage S --scene-seed X` runs that one scene alone. Scene generators draw from
// SceneRandom (std::mt19937_64 and hand-written distributions; no std::*_distribution, whose output is
// implementation-defined), so a seed gives the same scene everywhere. Sensor noise added by the stages' test helpers
// may use std::normal_distribution (processing/testing's Kinect noise): the same with libstdc++.
//
// Library first: `relume bench --suite random` (apps/relume/bench_command.cc) only parses
// its arguments and calls RunSuites; tests call the suites directly at small sizes.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace relume::bench {

struct SuiteOptions {
  int scenes = 20;         // scenes per suite
  std::uint64_t seed = 1;  // the suite's seed; scene i uses SceneSeed(seed, i)
  bool quick = false;      // smaller images and fewer samples (CI and tests)
  // Set: one scene, this seed (a scene of suite.csv reproduced alone); `scenes` and `seed`
  // are then ignored.
  std::optional<std::uint64_t> scene_seed;
  // Multiplies the rays of the renders' bounce-light quadrature (the IRM bounces suite's truth
  // and photographs): its Monte Carlo noise is in every error, the floor's too, so a larger
  // factor shows how much of an error is render noise. 1: the size's default.
  int truth_rays_factor = 1;
  bool IsValid(std::string* why) const;
  int SceneCount() const { return scene_seed ? 1 : scenes; }
  std::uint64_t SeedOf(int index) const;  // the seed of scene `index` (< SceneCount())
};

// The seed of scene `index` of a suite seeded with `suite_seed` (SplitMix64 of both).
std::uint64_t SceneSeed(std::uint64_t suite_seed, int index);
// SplitMix64's output function (Steele, Lea, Flood 2014): a well-mixed 64-bit hash of z.
std::uint64_t SplitMix64Mix(std::uint64_t z);

// A portable random source for scene generators: the same numbers on every platform.
class SceneRandom {
 public:
  explicit SceneRandom(std::uint64_t seed) : engine_(seed) {}
  double Uniform(double lo, double hi);  // [lo, hi)
  int Int(int lo, int hi);               // [lo, hi], inclusive
  double Gaussian();                     // N(0, 1), Box-Muller
  bool Chance(double p) { return Uniform(0.0, 1.0) < p; }
  std::uint64_t Next() { return engine_(); }

 private:
  std::mt19937_64 engine_;
};

// One scene's result: the method's error and the floor's (NaN when the stage failed on the
// scene; the reason goes in notes).
struct SceneResult {
  std::uint64_t seed = 0;
  double method = std::numeric_limits<double>::quiet_NaN();
  double floor = std::numeric_limits<double>::quiet_NaN();
  double seconds = 0.0;     // the method's run time on this scene
  std::string description;  // what the generator drew (object count, light, response, ...)
  std::string notes;        // further figures, or why the method failed
};

// Median, p90 and worst of a set of errors. Failed scenes (NaN) are counted and make the
// worst infinite; median and p90 are over the scenes that ran (linear interpolation between
// order statistics, as numpy's default percentile).
struct Distribution {
  int count = 0;   // scenes that ran
  int failed = 0;  // scenes whose error is NaN
  double median = std::numeric_limits<double>::quiet_NaN();
  double p90 = std::numeric_limits<double>::quiet_NaN();
  double worst = std::numeric_limits<double>::quiet_NaN();
  static Distribution Of(const std::vector<double>& values);
};
double Percentile(std::vector<double> values, double p);  // p in [0, 100]; NaNs dropped

// One suite's summary: one stage, one error metric, N scenes.
struct SuiteResult {
  std::string suite;   // e.g. "sh-ideal-depth"
  std::string stage;   // the relume stage it measures, e.g. "sh"
  std::string metric;  // e.g. "relit relative RMS"
  std::string method;  // what ran, e.g. "depth -> normals -> known-albedo SH fit -> relight"
  std::string floor;   // what the floor was given, e.g. "true normals"
  double goal_median = std::numeric_limits<double>::quiet_NaN();  // the goal (issue 20), NaN if none
  double goal_p90 = std::numeric_limits<double>::quiet_NaN();
  std::vector<SceneResult> scenes;
  Distribution method_errors, floor_errors;
  double seconds = 0.0;  // the whole run that produced it, generation and truth included
  // Fills method_errors and floor_errors from scenes.
  void Summarize();
  bool MeetsGoal() const;  // median and p90 within the goal (false without a goal)
};

// A registered suite: `relume bench --suite random --stage <stage>` runs every suite of the
// stage. One run may yield several results over the same scenes (one per error metric or
// region, e.g. IRM's lit and shadow pixels); each names itself in SuiteResult::suite.
struct SuiteEntry {
  std::string name;
  std::string stage;
  std::string description;
  std::function<std::vector<SuiteResult>(const SuiteOptions&)> run;
};
const std::vector<SuiteEntry>& Suites();

// Runs the suites of `stage` ("all" for every one); `progress` (may be empty) hears each
// suite's name before it runs. Throws InvalidArgumentError for an unknown stage or bad options.
std::vector<SuiteResult> RunSuites(const std::string& stage, const SuiteOptions& options,
                                   const std::function<void(const std::string&)>& progress = {});

// suite.md (the table), suite.csv (one row per scene) and suite.json in `dir`; returns the
// Markdown table.
std::string SuiteTable(const std::vector<SuiteResult>& results, const SuiteOptions& options);
std::string WriteSuiteOutputs(const std::string& dir, const std::vector<SuiteResult>& results,
                              const SuiteOptions& options);

}  // namespace relume::bench
