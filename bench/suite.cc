#include "bench/suite.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "bench/suites.h"
#include "core/error.h"

namespace relume::bench {

bool SuiteOptions::IsValid(std::string* why) const {
  if (scenes < 1 || scenes > 100000) {
    if (why) *why = "scenes must be between 1 and 100000 (got " + std::to_string(scenes) + ")";
    return false;
  }
  if (truth_rays_factor < 1 || truth_rays_factor > 64) {
    if (why) *why = "truth_rays_factor must be between 1 and 64 (got " + std::to_string(truth_rays_factor) + ")";
    return false;
  }
  return true;
}

std::uint64_t SceneSeed(std::uint64_t suite_seed, int index) {
  // SplitMix64 (Steele, Lea, Flood 2014) of the suite seed and the index: neighbouring seeds
  // and indices give unrelated scenes.
  return SplitMix64Mix(suite_seed * 0x9e3779b97f4a7c15ULL + static_cast<std::uint64_t>(index) + 1);
}

std::uint64_t SplitMix64Mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t SuiteOptions::SeedOf(int index) const {
  return scene_seed ? *scene_seed : SceneSeed(seed, index);
}

double SceneRandom::Uniform(double lo, double hi) {
  const double u = static_cast<double>(engine_() >> 11) * 0x1.0p-53;  // [0, 1), 53 bits
  return lo + (hi - lo) * u;
}

int SceneRandom::Int(int lo, int hi) {
  const std::uint64_t span = static_cast<std::uint64_t>(hi - lo) + 1;
  return lo + static_cast<int>(engine_() % span);
}

double SceneRandom::Gaussian() {
  const double u1 = 1.0 - Uniform(0.0, 1.0);  // (0, 1]
  const double u2 = Uniform(0.0, 1.0);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

double Percentile(std::vector<double> values, double p) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return std::isnan(v); }), values.end());
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(rank));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (rank - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

Distribution Distribution::Of(const std::vector<double>& values) {
  Distribution d;
  for (const double v : values) (std::isnan(v) ? d.failed : d.count) += 1;
  if (d.count == 0) return d;
  d.median = Percentile(values, 50.0);
  d.p90 = Percentile(values, 90.0);
  d.worst = d.failed > 0 ? std::numeric_limits<double>::infinity() : Percentile(values, 100.0);
  return d;
}

void SuiteResult::Summarize() {
  std::vector<double> method_values, floor_values;
  for (const SceneResult& s : scenes) {
    method_values.push_back(s.method);
    floor_values.push_back(s.floor);
  }
  method_errors = Distribution::Of(method_values);
  floor_errors = Distribution::Of(floor_values);
}

bool SuiteResult::MeetsGoal() const {
  if (std::isnan(goal_median) || std::isnan(goal_p90) || method_errors.failed > 0) return false;
  return method_errors.median <= goal_median && method_errors.p90 <= goal_p90;
}

const std::vector<SuiteEntry>& Suites() {
  // One line per suite; bench/suites.h declares the functions.
  static const std::vector<SuiteEntry> suites = {
      {"hdr-random-response", "hdr", "HDR radiance, 5 frames, random monotone responses", RunHdrSuite},
      {"sh-ideal-depth", "sh",
       "RGB-D SH lighting + relighting, exact depth, random objects under random lamps and sky (no cast shadows)",
       RunShIdealDepthSuite},
      {"sh-kinect-noise", "sh", "as sh-ideal-depth with Kinect-like depth noise", RunShKinectNoiseSuite},
      {"sh-smooth-light", "sh", "as sh-ideal-depth under smooth lights (sky and broad lobes) that SH can represent",
       RunShSmoothLightSuite},
      {"sh-smooth-light-bounces", "sh", "as sh-smooth-light rendered with 3 diffuse bounces (interreflection)",
       RunShSmoothLightBouncesSuite},
      {"irm-outdoor", "irm", "IRM relighting on random outdoor scenes: lit, shadow, penumbra", RunIrmSuite},
      {"irm-outdoor-bounces", "irm", "as irm-outdoor rendered with 3 diffuse bounces (interreflection)",
       RunIrmBouncesSuite},
      {"radiosity-rooms", "radiosity",
       "reflectance estimation with radiosity indirect light, random furnished rooms, per-material albedo",
       RunRadiositySuite},
      {"radiosity-rooms-chart", "radiosity",
       "as radiosity-rooms with photographs in unknown units and the absolute scale from a grey chart",
       RunRadiosityChartSuite},
  };
  return suites;
}

std::vector<SuiteResult> RunSuites(const std::string& stage, const SuiteOptions& options,
                                   const std::function<void(const std::string&)>& progress) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgumentError("bench suite: " + why);
  std::string stages;
  bool known = stage == "all";
  for (const SuiteEntry& e : Suites()) {
    known = known || e.stage == stage;
    if (stages.find(e.stage) == std::string::npos) stages += e.stage + ", ";
  }
  if (!known) {
    throw InvalidArgumentError("--stage " + stage + ": the stages with a random-scene suite are " + stages + "all");
  }
  std::vector<SuiteResult> results;
  for (const SuiteEntry& e : Suites()) {
    if (stage != "all" && e.stage != stage) continue;
    if (progress) progress(e.name);
    const auto start = std::chrono::steady_clock::now();
    std::vector<SuiteResult> run = e.run(options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    for (SuiteResult& r : run) {
      if (r.suite.empty()) r.suite = e.name;
      r.stage = e.stage;
      r.seconds = seconds;
      r.Summarize();
      results.push_back(std::move(r));
    }
  }
  return results;
}

namespace {

std::string Num(double v) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return "failed";
  std::ostringstream s;
  s << std::setprecision(3) << v;
  return s.str();
}

std::string Percent(double v) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return "failed";
  std::ostringstream s;
  s << std::fixed << std::setprecision(v < 0.1 ? 2 : 1) << 100.0 * v << " %";
  return s.str();
}

// Relative errors print as percentages; absolute ones (albedo) as numbers.
bool IsRelative(const SuiteResult& r) {
  return r.metric.find("relative") != std::string::npos;
}

// null for NaN (no value), "failed" for the infinite worst of a suite with failed scenes.
nlohmann::json JsonNumber(double v) {
  if (std::isnan(v)) return nullptr;
  if (std::isinf(v)) return "failed";
  return v;
}

nlohmann::json DistributionJson(const Distribution& d) {
  const auto num = JsonNumber;
  return {{"scenes", d.count},
          {"failed", d.failed},
          {"median", num(d.median)},
          {"p90", num(d.p90)},
          {"worst", num(d.worst)}};
}

std::string CsvField(std::string s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string SuiteTable(const std::vector<SuiteResult>& results, const SuiteOptions& options) {
  std::ostringstream md;
  md << "Random-scene suites: "
     << (options.scene_seed ? "the scene of seed " + std::to_string(*options.scene_seed)
                            : std::to_string(options.scenes) + " scene(s) each, seed " + std::to_string(options.seed))
     << (options.quick ? ", quick sizes" : "") << ".\n\n"
     << "| suite | metric | median | p90 | worst | floor median | floor p90 | floor worst | floor given | goal "
        "(median / p90) | met | s/scene |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SuiteResult& r : results) {
    const auto f = IsRelative(r) ? Percent : Num;
    const std::string goal = std::isnan(r.goal_median) ? std::string("-") : f(r.goal_median) + " / " + f(r.goal_p90);
    const Distribution& m = r.method_errors;
    md << "| " << r.suite << " | " << r.metric << " | " << f(m.median) << " | " << f(m.p90) << " | " << f(m.worst)
       << (m.failed ? " (" + std::to_string(m.failed) + " failed)" : std::string()) << " | " << f(r.floor_errors.median)
       << " | " << f(r.floor_errors.p90) << " | " << f(r.floor_errors.worst) << " | " << r.floor << " | " << goal
       << " | "
       << (std::isnan(r.goal_median) ? "-"
           : r.MeetsGoal()           ? "yes"
                                     : "NO")
       << " | " << Num(r.scenes.empty() ? 0.0 : r.seconds / static_cast<double>(r.scenes.size())) << " |\n";
  }
  return md.str();
}

std::string WriteSuiteOutputs(const std::string& dir, const std::vector<SuiteResult>& results,
                              const SuiteOptions& options) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError(dir, "cannot create the output folder: " + ec.message());
  const std::string md = SuiteTable(results, options);
  nlohmann::json json = {{"scenes", options.SceneCount()}, {"seed", options.seed}, {"quick", options.quick}};
  if (options.scene_seed) json["scene_seed"] = *options.scene_seed;
  std::ostringstream csv;
  csv << "suite,stage,scene,seed,method_error,floor_error,seconds,description,notes\n";
  for (const SuiteResult& r : results) {
    nlohmann::json scenes = nlohmann::json::array();
    for (std::size_t i = 0; i < r.scenes.size(); ++i) {
      const SceneResult& s = r.scenes[i];
      csv << r.suite << "," << r.stage << "," << i << "," << s.seed << "," << std::setprecision(6) << s.method << ","
          << s.floor << "," << s.seconds << "," << CsvField(s.description) << "," << CsvField(s.notes) << "\n";
      scenes.push_back({{"seed", s.seed},
                        {"method", JsonNumber(s.method)},
                        {"floor", JsonNumber(s.floor)},
                        {"seconds", s.seconds},
                        {"description", s.description},
                        {"notes", s.notes}});
    }
    json["suites"].push_back({{"suite", r.suite},
                              {"stage", r.stage},
                              {"metric", r.metric},
                              {"method", r.method},
                              {"floor", r.floor},
                              {"goal_median", JsonNumber(r.goal_median)},
                              {"goal_p90", JsonNumber(r.goal_p90)},
                              {"meets_goal", r.MeetsGoal()},
                              {"method_errors", DistributionJson(r.method_errors)},
                              {"floor_errors", DistributionJson(r.floor_errors)},
                              {"seconds", r.seconds},
                              {"scene_results", scenes}});
  }
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream out(fs::path(dir) / name);
    out << text;
    if (!out) throw IoError((fs::path(dir) / name).string(), "cannot write it (disk full? no permission?)");
  };
  write("suite.md", md);
  write("suite.csv", csv.str());
  write("suite.json", json.dump(2) + "\n");
  return md;
}

}  // namespace relume::bench
