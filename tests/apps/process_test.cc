// The `relume process` frame: content-keyed stage reuse, frame selection, and the radiance
// pipeline end to end on a small simulated session (against the world's truth).
#include "pipeline/process.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "capture/session.h"
#include "core/error.h"
#include "pipeline/stage_cache.h"
#include "rig/session_truth.h"
#include "tests/apps/cli_runner.h"

namespace relume::pipeline {
namespace {
namespace fs = std::filesystem;
using relume::testing::ReadJsonFile;

fs::path TempDir(const std::string& name) {
  return relume::testing::FreshTempDir("process_test", name);
}

TEST(StageKeyTest, EveryFieldAndItsOrderMatter) {
  const std::string base = StageKey().Add("a", 1).Add("b", 0.5).Hex();
  EXPECT_EQ(base, StageKey().Add("a", 1).Add("b", 0.5).Hex());
  EXPECT_NE(base, StageKey().Add("b", 0.5).Add("a", 1).Hex());
  EXPECT_NE(base, StageKey().Add("a", 1).Add("b", 0.5000000001).Hex());
  EXPECT_NE(base, StageKey().Add("a", 2).Add("b", 0.5).Hex());
  // Length prefixes keep field boundaries apart.
  EXPECT_NE(StageKey().Add("x", "ab").Add("y", "c").Hex(), StageKey().Add("x", "a").Add("y", "bc").Hex());
  EXPECT_EQ(base.size(), 64u);
}

TEST(StageCacheTest, ReusesCompleteStagesAndRecomputesChangedOnes) {
  const fs::path root = TempDir("cache");
  StageCache cache(root);
  int runs = 0;
  auto produce = [&](const fs::path& dir) {
    ++runs;
    std::ofstream(dir / "out.txt") << "result " << runs;
  };
  const StageKey key = StageKey().Add("input", "abc").Add("knob", 3);
  const StageStore::Result first = cache.Run("normals", key, produce);
  EXPECT_FALSE(first.reused);
  EXPECT_TRUE(fs::exists(first.dir / "out.txt"));
  EXPECT_TRUE(fs::exists(first.dir / "stage.json"));
  const StageStore::Result second = cache.Run("normals", key, produce);
  EXPECT_TRUE(second.reused);
  EXPECT_EQ(second.dir, first.dir);
  EXPECT_EQ(runs, 1);
  const StageStore::Result changed = cache.Run("normals", StageKey().Add("input", "abc").Add("knob", 4), produce);
  EXPECT_FALSE(changed.reused);
  EXPECT_NE(changed.dir, first.dir);
  EXPECT_EQ(runs, 2);
  // --force recomputes and replaces the folder.
  StageCache forced(root, /*reuse=*/false);
  EXPECT_FALSE(forced.Run("normals", key, produce).reused);
  EXPECT_EQ(runs, 3);
  fs::remove_all(root);
}

TEST(StageCacheTest, ResultsOfOtherCodeAreRecomputed) {
  const fs::path root = TempDir("code");
  int runs = 0;
  auto produce = [&](const fs::path&) { ++runs; };
  const StageKey key = StageKey().Add("input", "abc");
  EXPECT_FALSE(StageCache(root, true, "relume 0.1.0, code aaaa").Run("fit", key, produce).reused);
  EXPECT_TRUE(StageCache(root, true, "relume 0.1.0, code aaaa").Run("fit", key, produce).reused);
  EXPECT_FALSE(StageCache(root, true, "relume 0.1.0, code bbbb").Run("fit", key, produce).reused);
  EXPECT_EQ(runs, 2);
  // The default holds the hash of the sources that compute stage results (16 hex digits), made by
  // the build: the same in this test as in the relume program built from the same sources.
  const std::string& version = CodeVersion();
  const std::size_t code = version.find(", code ");
  ASSERT_NE(code, std::string::npos) << version;
  const std::string hash = version.substr(code + 7);
  EXPECT_EQ(hash.size(), 16u) << version;
  EXPECT_EQ(hash.find_first_not_of("0123456789abcdef"), std::string::npos) << version;
  EXPECT_NE(version.find("opencv "), std::string::npos) << version;
  EXPECT_NE(version.find("embree "), std::string::npos) << version;
  fs::remove_all(root);
}

// The relume program and this test were built from the same sources: a stage the program
// Records tests/data/rigs/sim-tiny-irm.yaml (two DSLR brackets of a small outdoor scene) into `session`.
void CaptureTinyIrmSession(const fs::path& session) {
  const testing::CliResult capture = testing::RunRelume("capture --rig " + std::string(RELUME_SOURCE_DIR) +
                                                        "/tests/data/rigs/sim-tiny-irm.yaml --out " + session.string());
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
}

// computed carries the code version this test computes.
TEST(ProcessCliTest, TheProgramAndTheLibraryShareTheCodeVersion) {
  const fs::path dir = TempDir("shared_code");
  ASSERT_NO_FATAL_FAILURE(CaptureTinyIrmSession(dir / "session"));
  const testing::CliResult run = testing::RunRelume("process " + (dir / "session").string() +
                                                    " --pipeline radiance --out " + (dir / "out").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  int manifests = 0;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir / "out" / "stages")) {
    if (e.path().filename() != "stage.json") continue;
    ++manifests;
    EXPECT_NE(fs::path(e.path()).parent_path().string().find("radiance"), std::string::npos);
    EXPECT_EQ(ReadJsonFile(e.path())["code"], CodeVersion());
  }
  EXPECT_GT(manifests, 0);
  fs::remove_all(dir);
}

TEST(StageCacheTest, AStageStoppedMidwayIsRecomputedNotReused) {
  const fs::path root = TempDir("partial");
  StageCache cache(root);
  const StageKey key = StageKey().Add("input", "abc");
  EXPECT_THROW(cache.Run("fit", key,
                         [](const fs::path& dir) {
                           std::ofstream(dir / "half.txt") << "half";
                           throw InvalidArgumentError("stopped");
                         }),
               InvalidArgumentError);
  EXPECT_FALSE(cache.IsComplete("fit", key));
  EXPECT_FALSE(fs::exists(cache.DirFor("fit", key)));
  bool ran = false;
  const StageStore::Result result = cache.Run("fit", key, [&](const fs::path& dir) {
    ran = true;
    EXPECT_FALSE(fs::exists(dir / "half.txt"));  // the unfinished folder was cleared
  });
  EXPECT_TRUE(ran);
  EXPECT_FALSE(result.reused);
  fs::remove_all(root);
}

// How many of a summary's decisions are `action` for `stage` (any stage when empty).
int CountDecisions(const nlohmann::json& summary, const std::string& stage, const std::string& action) {
  int count = 0;
  for (const nlohmann::json& d : summary["decisions"]) {
    count += (stage.empty() || d["stage"] == stage) && d["action"] == action;
  }
  return count;
}

TEST(ProcessCliTest, RadiancePipelineMatchesTruthAndReusesStages) {
  const fs::path dir = TempDir("cli");
  const fs::path session = dir / "session";
  const std::string rig = std::string(RELUME_SOURCE_DIR) + "/tests/data/rigs/sim-tiny-outdoor.yaml";
  const testing::CliResult capture = testing::RunRelume("capture --rig " + rig + " --out " + session.string());
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  ASSERT_TRUE(fs::exists(session / "rig" / "scene.yaml")) << "the session keeps its world";

  const fs::path out = dir / "radiance";
  const testing::CliResult first =
      testing::RunRelume("process " + session.string() + " --pipeline radiance --out " + out.string());
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const nlohmann::json summary = ReadJsonFile(out / "summary.json");
  ASSERT_EQ(summary["metrics"]["brackets"].size(), 4u);  // DSLR and phone, 09:00 and 15:00
  double dslr_scale = 0.0;
  for (const nlohmann::json& b : summary["metrics"]["brackets"]) {
    // Linear radiance within 2% (RMS, after one scale) of the world's truth, with sensor noise.
    EXPECT_LT(b["truth_relative_rms"].get<double>(), 0.02) << b.dump();
    if (b["device"] == "sim:dslr") {
      // Raw frames: the same scale at 09:00 and 15:00, so brackets can be compared directly.
      const double scale = b["truth_scale"].get<double>();
      if (dslr_scale > 0.0) {
        EXPECT_NEAR(scale / dslr_scale, 1.0, 2e-3);
      }
      dslr_scale = scale;
    }
  }
  EXPECT_NE(first.output.find("no response recorded for sim:phone"), std::string::npos) << first.output;

  // Unchanged: every stage reused. A changed knob: every radiance stage recomputed.
  const testing::CliResult again =
      testing::RunRelume("process " + session.string() + " --pipeline radiance --out " + out.string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  // Unchanged: every bracket's radiance and its comparison with the truth are reused (the
  // world is not rendered again).
  const nlohmann::json again_summary = ReadJsonFile(out / "summary.json");
  EXPECT_EQ(CountDecisions(again_summary, "radiance", "reuse"), 4) << again.output;
  EXPECT_EQ(CountDecisions(again_summary, "radiance-truth", "reuse"), 4) << again.output;
  EXPECT_EQ(CountDecisions(again_summary, "", "run"), 0) << again.output;
  EXPECT_EQ(again_summary["metrics"]["brackets"], summary["metrics"]["brackets"]);
  const testing::CliResult knob = testing::RunRelume(
      "process " + session.string() + " --pipeline radiance --set merge_saturation_margin=8 --out " + out.string());
  ASSERT_EQ(knob.exit_code, 0) << knob.output;
  const nlohmann::json knob_summary = ReadJsonFile(out / "summary.json");
  EXPECT_EQ(CountDecisions(knob_summary, "radiance", "run"), 4) << knob.output;
  EXPECT_EQ(CountDecisions(knob_summary, "radiance-truth", "run"), 4) << knob.output;

  // The report loads in a browser with every image and figure.
  ASSERT_TRUE(fs::exists(out / "report.html"));
  const relume::testing::CliResult chromium = relume::testing::LoadInChromium(out / "report.html");
  ASSERT_EQ(chromium.exit_code, 0) << "chromium failed; install it with scripts/install-deps.sh";
  const std::string& dom = chromium.output;
  EXPECT_NE(dom.find("data-images-broken=\"0\""), std::string::npos) << dom.substr(0, 2000);
  EXPECT_NE(dom.find("data-images-loaded=\"6\""), std::string::npos)
      << "one preview per bracket, the first in the overview, and the RGB-D sensor's factory response";
  EXPECT_NE(dom.find("sim:rgbd colour camera, factory response"), std::string::npos);
  // Decisions are collapsed, with their counts per action.
  EXPECT_NE(dom.find("<details class=\"decisions\"><summary>"), std::string::npos);
  EXPECT_NE(dom.find("data-figures=\"1\""), std::string::npos) << "the timeline";
  EXPECT_NE(dom.find("id=\"pipeline-radiance\""), std::string::npos);
  // The overview comes first: each pipeline's headline figures, before the session's details.
  const std::size_t results = dom.find("id=\"results\"");
  ASSERT_NE(results, std::string::npos);
  EXPECT_LT(results, dom.find("id=\"devices\""));
  // The session line says which devices and what time span.
  EXPECT_NE(dom.find("<th>devices</th><td>sim:"), std::string::npos) << dom.substr(0, 3000);
  const std::size_t span = dom.find("<th>frames</th><td>");
  ASSERT_NE(span, std::string::npos);
  EXPECT_NE(dom.find(" to 2026-", span), std::string::npos) << dom.substr(span, 200);
  EXPECT_NE(dom.find("bracket(s) linearised; against the truth: worst relative RMS", results), std::string::npos);
  EXPECT_NE(dom.find("truth_relative_rms"), std::string::npos);

  // Errors a user can make, each named.
  const testing::CliResult no_pipeline = testing::RunRelume("process " + session.string() + " --pipeline nope");
  EXPECT_NE(no_pipeline.exit_code, 0);
  EXPECT_NE(no_pipeline.output.find("no pipeline named 'nope'"), std::string::npos) << no_pipeline.output;
  const testing::CliResult no_session = testing::RunRelume("process " + dir.string() + " --pipeline radiance");
  EXPECT_NE(no_session.exit_code, 0);
  EXPECT_NE(no_session.output.find("is not a relume session"), std::string::npos) << no_session.output;
  const testing::CliResult bad_frames =
      testing::RunRelume("process " + session.string() + " --pipeline radiance --source bracket:99");
  EXPECT_NE(bad_frames.exit_code, 0);
  EXPECT_NE(bad_frames.output.find("matches no frame"), std::string::npos) << bad_frames.output;
  const testing::CliResult bad_knob =
      testing::RunRelume("process " + session.string() + " --pipeline radiance --set merge_black_margin=two");
  EXPECT_NE(bad_knob.exit_code, 0);
  EXPECT_NE(bad_knob.output.find("merge_black_margin=two: expected an integer"), std::string::npos) << bad_knob.output;
  fs::remove_all(dir);
}

// The bytes of the one file named `name` under `dir` ("" when there is none or more than one).
std::string TheOneFile(const fs::path& dir, const std::string& name) {
  std::vector<fs::path> found;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir)) {
    if (e.path().filename() == name) found.push_back(e.path());
  }
  if (found.size() != 1) return "";
  std::ifstream in(found.front(), std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Issue 19: ground truth reaches the pipelines only through PipelineRequest::load_truth, and only
// for evaluation. Through the library with no loader, a simulated session is processed as a real
// capture would be: no comparison, a decision saying so, and the very same relit image as with
// the truth loaded (which adds its comparison and changes nothing else).
TEST(ProcessLibraryTest, TruthComesOnlyFromTheLoaderAndChangesNoResult) {
  const fs::path dir = TempDir("truth_loader");
  ASSERT_NO_FATAL_FAILURE(CaptureTinyIrmSession(dir / "session"));
  PipelineRequest request;
  request.session_dir = dir / "session";
  request.pipeline = "irm";
  request.out_dir = dir / "without";
  const ProcessResult without = ProcessSession(request);
  ASSERT_TRUE(without.failed.empty());
  ASSERT_EQ(without.reports.size(), 1u);
  const nlohmann::json& a = without.reports[0].summary;
  EXPECT_FALSE(a["metrics"].contains("truth")) << a["metrics"].dump();
  bool said = false;
  for (const nlohmann::json& d : a["decisions"]) {
    said |= d["reason"].get<std::string>().find("no ground truth for this session") != std::string::npos;
  }
  EXPECT_TRUE(said) << a["decisions"].dump(1);

  request.out_dir = dir / "with";
  request.load_truth = rig::LoadSessionTruth;
  const ProcessResult with = ProcessSession(request);
  ASSERT_TRUE(with.failed.empty());
  const nlohmann::json& b = with.reports[0].summary;
  ASSERT_TRUE(b["metrics"].contains("truth")) << b["metrics"].dump();
  EXPECT_LT(b["metrics"]["truth"]["relit"]["relative_rms_lit"].get<double>(), 0.05) << b["metrics"]["truth"].dump();

  const std::string relit_without = TheOneFile(dir / "without", "relit.exr");
  ASSERT_FALSE(relit_without.empty());
  EXPECT_TRUE(relit_without == TheOneFile(dir / "with", "relit.exr")) << "the truth changed a result";
  fs::remove_all(dir);
}

// A summary's metrics without run times (keys stage_seconds and *_s), which differ run to run.
nlohmann::json WithoutTimes(nlohmann::json j) {
  if (!j.is_object()) return j;
  nlohmann::json out = nlohmann::json::object();
  for (auto& [key, value] : j.items()) {
    const bool time = key == "stage_seconds" || (key.size() > 2 && key.compare(key.size() - 2, 2, "_s") == 0);
    if (!time) out[key] = WithoutTimes(value);
  }
  return out;
}

// Issue 21: a pipeline runs against a StageStore. The in-memory store (TemporaryStageStore) gives
// the same results as the directory store and leaves no stages/ folder; two runs through one store
// reuse each other's stages; its outputs exist while it lives and go with it.
TEST(ProcessLibraryTest, ATemporaryStoreGivesTheSameResultsAndKeepsNothing) {
  const fs::path dir = TempDir("temporary_store");
  ASSERT_NO_FATAL_FAILURE(CaptureTinyIrmSession(dir / "session"));
  PipelineRequest request;
  request.session_dir = dir / "session";
  request.pipeline = "irm";
  request.load_truth = rig::LoadSessionTruth;
  request.out_dir = dir / "directory";
  const ProcessResult kept = ProcessSession(request);
  ASSERT_TRUE(kept.failed.empty());
  EXPECT_TRUE(fs::is_directory(dir / "directory" / "stages"));

  fs::path root;
  {
    auto store = std::make_shared<TemporaryStageStore>();
    root = store->root();
    request.store = store;
    request.out_dir = dir / "memory";
    const ProcessResult first = ProcessSession(request);
    ASSERT_TRUE(first.failed.empty());
    const nlohmann::json& s = first.reports[0].summary;
    EXPECT_FALSE(fs::exists(dir / "memory" / "stages"));
    EXPECT_EQ(s["stages"], store->Describe());
    EXPECT_EQ(WithoutTimes(s["metrics"]), WithoutTimes(kept.reports[0].summary["metrics"]))
        << "a store changed a result";
    int outputs_in_store = 0;
    for (const nlohmann::json& o : s["outputs"]) {
      const fs::path path = fs::weakly_canonical(dir / "memory" / o["path"].get<std::string>());
      if (path.string().rfind(fs::weakly_canonical(root).string(), 0) != 0) continue;
      ++outputs_in_store;
      EXPECT_TRUE(fs::exists(path)) << path;
    }
    EXPECT_GT(outputs_in_store, 0) << s["outputs"].dump(1);

    request.out_dir = dir / "memory-again";
    const nlohmann::json again = ProcessSession(request).reports[0].summary;
    int runs = 0, reuses = 0;
    for (const nlohmann::json& d : again["decisions"]) {
      if (!d.contains("cache")) continue;  // a stage store event
      runs += d["action"] == "run";
      reuses += d["action"] == "reuse";
    }
    EXPECT_EQ(runs, 0) << again["decisions"].dump(1);
    EXPECT_GT(reuses, 0);
    request.store.reset();
  }
  EXPECT_FALSE(fs::exists(root)) << "the store's folder outlived it";
  fs::remove_all(dir);
}

// The radiometric calibrations of a session (capture itself records others, e.g. RGB-D geometry).
std::vector<capture::CalibrationRecord> Calibrations(const fs::path& session) {
  std::vector<capture::CalibrationRecord> radiometric;
  for (const capture::CalibrationRecord& c : capture::SessionReader(session).Calibrations()) {
    if (c.kind == "response" || c.kind == "profile") radiometric.push_back(c);
  }
  return radiometric;
}

TEST(ProcessCliTest, CalibrationsFromTheSessionAreStoredThereAndApplied) {
  const fs::path dir = TempDir("calibrate");
  const std::string source = RELUME_SOURCE_DIR;
  // The chart shot: found, fitted, stored in the session with the frames it came from.
  const fs::path chart_session = dir / "chart";
  ASSERT_EQ(
      testing::RunRelume("capture --rig " + source + "/config/rigs/sim-chart.yaml --out " + chart_session.string())
          .exit_code,
      0);
  const testing::CliResult chart = testing::RunRelume(
      "calibrate chart --session " + chart_session.string() + " --frames bracket:1 --reference " + source +
      "/config/colorchecker/xrite_classic_2014_lab_d50.yaml --out " + (dir / "profile.json").string());
  ASSERT_EQ(chart.exit_code, 0) << chart.output;
  EXPECT_TRUE(fs::exists(dir / "profile.json")) << "the standalone profile file";
  const std::vector<capture::CalibrationRecord> stored = Calibrations(chart_session);
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].kind, "profile");
  EXPECT_EQ(stored[0].device_id, "sim:dslr");
  EXPECT_EQ(stored[0].source_frame_ids, (std::vector<std::int64_t>{1, 2}));
  const nlohmann::json report = ReadJsonFile(dir / "profile_report" / "chart_report.json");
  EXPECT_LT(report["fit"]["mean_delta_e_2000"].get<double>(), 1.0) << report["fit"].dump();
  const testing::CliResult applied =
      testing::RunRelume("process " + chart_session.string() + " --pipeline radiance --out " + (dir / "p").string());
  ASSERT_EQ(applied.exit_code, 0) << applied.output;
  EXPECT_NE(applied.output.find("applying colour profile (calibration " + std::to_string(stored[0].id) + ")"),
            std::string::npos)
      << applied.output;
  // The report shows the chart's patches with their Delta E 2000 (24 cells, the fit's values).
  {
    std::ostringstream page;
    page << std::ifstream(dir / "p" / "report.html").rdbuf();
    const std::string html = page.str();
    const std::size_t grid = html.find("&#916;E2000 per patch");
    ASSERT_NE(grid, std::string::npos);
    const std::size_t end = html.find("</table>", grid);
    int cells = 0;
    for (std::size_t at = html.find("<td style=", grid); at < end; at = html.find("<td style=", at + 1)) ++cells;
    EXPECT_EQ(cells, 24);
  }

  // An EV-only camera's response, recovered from one bracket and stored: later brackets of that
  // camera are linearised with it instead of recovering their own.
  const fs::path session = dir / "outdoor";
  ASSERT_EQ(
      testing::RunRelume("capture --rig " + source + "/tests/data/rigs/sim-tiny-outdoor.yaml --out " + session.string())
          .exit_code,
      0);
  // Capture wrote the simulated RGB-D sensor's factory response (rig/factory_response.h); the
  // calibrate commands add theirs after it.
  ASSERT_EQ(Calibrations(session).size(), 1u);
  EXPECT_EQ(Calibrations(session)[0].kind, "response");
  EXPECT_EQ(Calibrations(session)[0].device_id, "sim:rgbd");
  const testing::CliResult response = testing::RunRelume("calibrate response --session " + session.string() +
                                                         " --frames bracket:2 --out " + (dir / "phone.json").string());
  ASSERT_EQ(response.exit_code, 0) << response.output;
  ASSERT_EQ(Calibrations(session).size(), 2u);
  EXPECT_EQ(Calibrations(session)[1].kind, "response");
  EXPECT_EQ(Calibrations(session)[1].device_id, "sim:phone");
  // The chart shot's profile, stored also in the day's session of the same DSLR.
  const testing::CliResult store_in = testing::RunRelume(
      "calibrate chart --session " + chart_session.string() + " --frames bracket:1 --store-in " + session.string() +
      " --reference " + source + "/config/colorchecker/xrite_classic_2014_lab_d50.yaml --out " +
      (dir / "profile2.json").string());
  ASSERT_EQ(store_in.exit_code, 0) << store_in.output;
  ASSERT_EQ(Calibrations(session).size(), 3u);
  EXPECT_EQ(Calibrations(session)[2].kind, "profile");
  EXPECT_EQ(Calibrations(session)[2].device_id, "sim:dslr");
  const testing::CliResult processed =
      testing::RunRelume("process " + session.string() + " --pipeline radiance --out " + (dir / "q").string());
  ASSERT_EQ(processed.exit_code, 0) << processed.output;
  EXPECT_EQ(processed.output.find("no response recorded for sim:phone"), std::string::npos) << processed.output;
  EXPECT_NE(processed.output.find("applying colour profile"), std::string::npos) << processed.output;
  const nlohmann::json processed_summary = ReadJsonFile(dir / "q" / "summary.json");
  for (const nlohmann::json& b : processed_summary["metrics"]["brackets"]) {
    EXPECT_LT(b["truth_relative_rms"].get<double>(), 0.03) << b.dump();
  }
  // Raw frames need no response: a clear refusal.
  const testing::CliResult raw = testing::RunRelume("calibrate response --session " + session.string() +
                                                    " --frames bracket:1 --out " + (dir / "raw.json").string());
  EXPECT_NE(raw.exit_code, 0);
  EXPECT_NE(raw.output.find("need no response curve"), std::string::npos) << raw.output;
  fs::remove_all(dir);
}

// Knobs are declared once: `--list --pipeline` shows them with their defaults, a typo is refused
// before anything runs (no output folder made), with the closest knob's name.
TEST(ProcessCliTest, KnobsAreListedAndATypoIsRefusedBeforeAnythingRuns) {
  const testing::CliResult list = testing::RunRelume("process --list --pipeline irm");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find("bins=32"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("response_samples="), std::string::npos) << list.output;  // radiance knobs too
  EXPECT_EQ(list.output.find("sh_order"), std::string::npos) << list.output;           // not the SH pipeline's

  const fs::path dir = TempDir("typo");
  const fs::path out = dir / "out";
  const testing::CliResult typo = testing::RunRelume("process " + (dir / "no-session").string() + " --out " +
                                                     out.string() + " --pipeline irm --set bnis=16");
  testing::ExpectUserError(typo, "--set bnis=16: not a knob of the irm pipeline (did you mean bins?)");
  EXPECT_FALSE(fs::exists(out));
  const testing::CliResult other = testing::RunRelume("process " + (dir / "no-session").string() + " --out " +
                                                      out.string() + " --pipeline irm --set sh_order=1");
  testing::ExpectUserError(other, "--set sh_order=1: not a knob of the irm pipeline");
  fs::remove_all(dir);
}

// The command's output fits on a screen: decisions that shape the result (alike ones grouped),
// stage cache events counted, files only with --verbose, and each pipeline's headline figures
// at the end (issue 24).
TEST(ProcessCliTest, OutputIsShortAndEndsWithTheHeadlineFigures) {
  const fs::path dir = TempDir("short_output");
  ASSERT_NO_FATAL_FAILURE(CaptureTinyIrmSession(dir / "session"));
  const std::string command = "process " + (dir / "session").string() + " --out " + (dir / "out").string();
  const testing::CliResult quiet = testing::RunRelume(command);
  ASSERT_EQ(quiet.exit_code, 0) << quiet.output;
  const auto lines = std::count(quiet.output.begin(), quiet.output.end(), '\n');
  EXPECT_LE(lines, 40) << quiet.output;
  EXPECT_EQ(quiet.output.find("wrote "), std::string::npos) << quiet.output;
  EXPECT_EQ(quiet.output.find("inputs and settings unchanged"), std::string::npos) << quiet.output;
  const std::size_t summary = quiet.output.find("summary:\n");
  ASSERT_NE(summary, std::string::npos) << quiet.output;
  EXPECT_NE(quiet.output.find("  irm", summary), std::string::npos) << quiet.output;
  EXPECT_NE(quiet.output.find("against the truth: lit ", summary), std::string::npos) << quiet.output;
  EXPECT_NE(quiet.output.find("  sh         not run: ", summary), std::string::npos) << quiet.output;
  const nlohmann::json irm = ReadJsonFile(dir / "out" / "irm" / "summary.json");
  EXPECT_NE(irm["headline"].get<std::string>().find("against the truth"), std::string::npos) << irm["headline"];

  // The report opens on the overview: the IRM's key images (source, relit to blink against it,
  // target, error against the truth) load from the output folder.
  const testing::CliResult chromium = testing::LoadInChromium(dir / "out" / "report.html");
  ASSERT_EQ(chromium.exit_code, 0) << "chromium failed; install it with scripts/install-deps.sh";
  const std::string& dom = chromium.output;
  EXPECT_NE(dom.find("data-images-broken=\"0\""), std::string::npos) << dom.substr(0, 2000);
  EXPECT_NE(dom.find("data-script-errors=\"0\""), std::string::npos) << dom.substr(0, 2000);
  const std::size_t results = dom.find("id=\"results\"");
  ASSERT_NE(results, std::string::npos);
  for (const char* alt : {"alt=\"irm source\"", "alt=\"irm relit\"", "alt=\"irm error vs truth\""}) {
    EXPECT_NE(dom.find(alt, results), std::string::npos) << alt;
  }
  EXPECT_NE(dom.find("class=\"blink\"", results), std::string::npos);
  // ... and within the first 1400 x 900 screen (the page measures its overview once laid out).
  const std::size_t bottom = dom.find("data-overview-bottom=\"");
  ASSERT_NE(bottom, std::string::npos);
  EXPECT_LE(std::stoi(dom.substr(bottom + 22)), 900) << dom.substr(bottom, 40);
  // Each pipeline's key figures, labelled with units.
  EXPECT_NE(dom.find("<td>relit vs truth, lit (per-pixel relative RMS)</td>"), std::string::npos);
  EXPECT_EQ(dom.find("cannot be read"), std::string::npos);

  // Unchanged rerun: the stages are counted as reused; --verbose lists them and every file.
  const testing::CliResult again = testing::RunRelume(command);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("0 stage(s) run, "), std::string::npos) << again.output;
  const testing::CliResult verbose = testing::RunRelume(command + " --verbose");
  ASSERT_EQ(verbose.exit_code, 0) << verbose.output;
  EXPECT_NE(verbose.output.find("wrote "), std::string::npos) << verbose.output;
  EXPECT_NE(verbose.output.find("inputs and settings unchanged"), std::string::npos) << verbose.output;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::pipeline
