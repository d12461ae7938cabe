// `relume batch --local N` through the binary (docs/batch.md): every session processed and
// gathered into the index, a rerun that reuses every stage, a worker killed mid-way listed as
// failed and rerun alone, and the errors a user can cause.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "batch/task.h"
#include "tests/apps/cli_runner.h"

namespace relume::batch {
namespace {
namespace fs = std::filesystem;
using relume::testing::ExpectUserError;
using relume::testing::ReadJsonFile;
using relume::testing::ReadText;
using relume::testing::RunCommand;
using relume::testing::RunRelume;

int CountOf(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Ten tiny simulated sessions (tests/data/rigs/sim-tiny-irm.yaml), recorded once for the suite.
class BatchCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(relume::testing::FreshTempDir("batch_cli", "suite"));
    const std::string rig = std::string(RELUME_SOURCE_DIR) + "/tests/data/rigs/sim-tiny-irm.yaml";
    for (int i = 0; i < 10; ++i) {
      std::string arguments = "capture --rig ";
      arguments += rig;
      arguments += " --out ";
      arguments += (*dir_ / "field" / ("day" + std::to_string(i)) / "session").string();
      const testing::CliResult capture = RunRelume(arguments);
      ASSERT_EQ(capture.exit_code, 0) << capture.output;
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static fs::path Field() { return *dir_ / "field"; }
  static fs::path* dir_;
};
fs::path* BatchCliTest::dir_ = nullptr;

// Every result.json and summary.json of the batch: stage cache events by action.
std::map<std::string, int> CacheActions(const fs::path& out) {
  std::map<std::string, int> actions;
  for (const auto& e : fs::directory_iterator(out / "sessions")) {
    const nlohmann::json summary = ReadJsonFile(e.path() / kResultFolder / "summary.json");
    for (const nlohmann::json& d : summary["decisions"]) {
      if (d.value("cache", false)) ++actions[d["action"].get<std::string>()];
    }
  }
  return actions;
}

TEST_F(BatchCliTest, LocalWorkersProcessEverySessionIntoOneIndexAndARerunReusesEveryStage) {
  const fs::path out = Field().parent_path() / "batch-all";
  // --set before the sessions: one value per --set, the glob is not taken for a knob.
  const std::string command = "batch --set bins=16 '" + (Field() / "*" / "session").string() + "' --out " +
                              out.string() + " --local 2 --pipeline irm";
  const testing::CliResult first = RunRelume(command);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("running 10 task(s) on 2 local worker(s)"), std::string::npos) << first.output;
  EXPECT_NE(first.output.find("10 session(s): 10 done; index: " + (out / "index.html").string()), std::string::npos)
      << first.output;
  EXPECT_EQ(CountOf(first.output, "irm: four IRMs; against the truth: lit "), 10) << first.output;

  const std::string csv = ReadText(out / "index.csv");
  EXPECT_EQ(CountOf(csv, "\n"), 11) << csv;
  EXPECT_EQ(CountOf(csv, ",done,"), 10) << csv;
  EXPECT_NE(csv.find("\"irm: relit vs truth, lit (per-pixel relative RMS) [%]\""), std::string::npos) << csv;
  const std::string html = ReadText(out / "index.html");
  EXPECT_NE(html.find("data-tasks=\"10\" data-done=\"10\" data-failed=\"0\""), std::string::npos);
  EXPECT_EQ(CountOf(html, ">report</a>"), 10);
  // Ten folders, one per session, each published whole; the plan kept the --set knob.
  int folders = 0;
  for (const auto& e : fs::directory_iterator(out / "sessions")) {
    ++folders;
    EXPECT_TRUE(fs::exists(e.path() / kResultFolder / "report.html")) << e.path();
    EXPECT_FALSE(fs::exists(e.path() / kWorkFolder)) << e.path();
    EXPECT_EQ(ReadJsonFile(e.path() / kResultFolder / "summary.json")["knobs"]["bins"], 16);
  }
  EXPECT_EQ(folders, 10);
  EXPECT_EQ(CacheActions(out).count("reuse"), 0u);

  // The same batch again: the stage cache of each session's folder reuses every stage.
  const testing::CliResult again = RunRelume(command);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  std::map<std::string, int> actions = CacheActions(out);
  EXPECT_EQ(actions["run"], 0) << "a rerun recomputed stages:\n" << again.output;
  EXPECT_GE(actions["reuse"], 10 * 8);
}

// Workers forked from `relume batch` (the default) and workers started as `relume batch-task`
// (--local-start exec) process the same sessions to the same bytes and figures; each forked
// task records its own process and writes its own log.
TEST_F(BatchCliTest, ForkedAndStartedWorkersGiveTheSameResults) {
  // Built with += (GCC 12 warns about a chain of + on these strings).
  std::string command = "batch --local 2 --pipeline irm";
  for (int i = 0; i < 3; ++i) {
    command += ' ';
    command += (Field() / ("day" + std::to_string(i)) / "session").string();
  }
  const fs::path forked = Field().parent_path() / "batch-forked";
  const fs::path started = Field().parent_path() / "batch-started";
  const testing::CliResult a = RunRelume(command + " --out " + forked.string());
  ASSERT_EQ(a.exit_code, 0) << a.output;
  EXPECT_NE(a.output.find(", forked from this process)"), std::string::npos) << a.output;
  const testing::CliResult b = RunRelume(command + " --local-start exec --out " + started.string());
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_NE(b.output.find(", each started as relume batch-task)"), std::string::npos) << b.output;

  std::set<long> pids;
  int relit = 0;
  for (const auto& e : fs::directory_iterator(forked / "sessions")) {
    const fs::path other = started / "sessions" / e.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    const TaskRecord record = ReadTaskRecord(e.path());
    EXPECT_EQ(record.state, TaskState::kDone);
    pids.insert(record.pid);
    const nlohmann::json mine = ReadJsonFile(e.path() / kResultFolder / kResultRecordFile)["pipelines"];
    const nlohmann::json theirs = ReadJsonFile(other / kResultFolder / kResultRecordFile)["pipelines"];
    ASSERT_EQ(mine.size(), theirs.size()) << e.path();
    for (std::size_t p = 0; p < mine.size(); ++p) {
      EXPECT_EQ(mine[p]["figures"], theirs[p]["figures"]) << e.path();
      EXPECT_EQ(mine[p]["headline"], theirs[p]["headline"]) << e.path();
    }
    for (const auto& f : fs::recursive_directory_iterator(e.path() / kResultFolder)) {
      if (f.path().filename() != "relit.exr") continue;
      ++relit;
      const fs::path twin = other / fs::relative(f.path(), e.path());
      EXPECT_EQ(ReadText(f.path()), ReadText(twin)) << f.path() << " differs from " << twin;
    }
  }
  EXPECT_EQ(relit, 3);
  EXPECT_EQ(pids.size(), 3u);  // a process of its own per task
  EXPECT_EQ(pids.count(0), 0u);
  int logs = 0;
  for (const auto& e : fs::directory_iterator(forked / "logs")) {
    ++logs;
    const std::string log = ReadText(e.path());
    EXPECT_EQ(CountOf(log, " done in "), 1) << e.path() << ":\n" << log;
  }
  EXPECT_EQ(logs, 3);
}

// A worker killed mid-way (SIGKILL) leaves no result: the batch lists the task as failed with its
// log, and --only-failed reruns that task alone, continuing from its completed stages.
TEST_F(BatchCliTest, AKilledWorkerIsListedFailedAndRerunAlone) {
  const fs::path dir = Field().parent_path();
  // A slower session (640x480), so that the kill lands while it runs.
  const std::string rig = ReadText(fs::path(RELUME_SOURCE_DIR) / "tests/data/rigs/sim-tiny-irm.yaml");
  std::string slow_rig = rig;
  slow_rig.replace(slow_rig.find("width: 160, height: 120"), 23, "width: 640, height: 480");
  slow_rig.replace(slow_rig.find("../../../config"), 15, std::string(RELUME_SOURCE_DIR) + "/config");
  std::ofstream(dir / "slow.yaml") << slow_rig;
  const fs::path slow = dir / "slow" / "session";
  const testing::CliResult capture =
      RunRelume("capture --rig " + (dir / "slow.yaml").string() + " --out " + slow.string());
  ASSERT_EQ(capture.exit_code, 0) << capture.output;

  const fs::path out = dir / "batch-kill";
  const fs::path log = dir / "batch-kill.txt";
  // In the background; the test follows the slow task's record and kills its worker.
  std::system((std::string(RELUME_BINARY) + " batch " + slow.string() + " " + (Field() / "day0/session").string() +
               " --out " + out.string() + " --local 2 --pipeline irm > " + log.string() + " 2>&1 &")
                  .c_str());
  fs::path slow_folder;
  long pid = 0;
  for (int i = 0; i < 1200 && pid == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!fs::exists(out / "sessions")) continue;
    for (const auto& e : fs::directory_iterator(out / "sessions")) {
      const TaskRecord record = ReadTaskRecord(e.path());
      if (record.session != fs::canonical(slow).string() || record.state != TaskState::kRunning) continue;
      bool stage_done = false;
      if (fs::exists(e.path() / kWorkFolder / "stages")) {
        for (const auto& s : fs::directory_iterator(e.path() / kWorkFolder / "stages")) {
          // A completed stage: its manifest is written inside <stage>.partial just before the
          // rename, so a .partial folder with stage.json is not one yet (killed there, it is
          // discarded and the rerun has nothing to reuse).
          if (s.path().extension() == ".partial") continue;
          stage_done = stage_done || fs::exists(s.path() / "stage.json");
        }
      }
      if (stage_done) {
        slow_folder = e.path();
        pid = record.pid;
      }
    }
  }
  ASSERT_NE(pid, 0) << "the slow task never got under way:\n" << ReadText(log);
  ASSERT_EQ(::kill(static_cast<pid_t>(pid), SIGKILL), 0);
  std::string output;
  for (int i = 0; i < 1200 && output.find(" session(s): ") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    output = ReadText(log);
  }
  EXPECT_NE(output.find("2 session(s): 1 done, 1 failed (task 0)"), std::string::npos) << output;
  EXPECT_NE(output.find("ended without a result (signal 9"), std::string::npos) << output;
  EXPECT_NE(output.find("relume: error: 1 task(s) failed"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(slow_folder / kResultFolder));
  EXPECT_TRUE(fs::exists(slow_folder / kWorkFolder));
  const std::string csv = ReadText(out / "index.csv");
  EXPECT_NE(csv.find("\n0," + fs::canonical(slow).string() + ",failed,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",logs/local-"), std::string::npos) << csv;
  EXPECT_NE(ReadText(out / "index.html").find("--only-failed"), std::string::npos);

  const testing::CliResult retry = RunRelume("batch --out " + out.string() + " --only-failed --local 2");
  ASSERT_EQ(retry.exit_code, 0) << retry.output;
  EXPECT_NE(retry.output.find("running 1 task(s)"), std::string::npos) << retry.output;
  EXPECT_NE(retry.output.find("2 session(s): 2 done"), std::string::npos) << retry.output;
  int reused = 0;
  const nlohmann::json summary = ReadJsonFile(slow_folder / kResultFolder / "summary.json");
  for (const nlohmann::json& d : summary["decisions"]) {
    reused += d.value("cache", false) && d["action"] == "reuse" ? 1 : 0;
  }
  EXPECT_GE(reused, 1) << "the rerun did not continue from the killed task's completed stages";
  // Nothing left to rerun.
  const testing::CliResult nothing = RunRelume("batch --out " + out.string() + " --only-failed --local 2");
  EXPECT_EQ(nothing.exit_code, 0) << nothing.output;
  EXPECT_NE(nothing.output.find("nothing to run"), std::string::npos) << nothing.output;
}

TEST_F(BatchCliTest, UserErrorsNameWhatIsWrongAndWhatToDo) {
  const fs::path dir = Field().parent_path();
  const std::string out = " --out " + (dir / "batch-errors").string();
  ExpectUserError(RunRelume("batch '" + (dir / "nowhere" / "*").string() + "'" + out), "matches nothing");
  fs::create_directories(dir / "notes");
  ExpectUserError(RunRelume("batch " + (dir / "notes").string() + out),
                  "notes is not a relume session (no session.sqlite)");
  const std::string one = " " + (Field() / "day0/session").string();
  ExpectUserError(RunRelume("batch" + one + out + " --set bnis=16 --pipeline irm"), "did you mean bins?");
  ExpectUserError(RunRelume("batch" + one + out + " --pipeline nosuch"), "--pipeline nosuch: no such pipeline");
  ExpectUserError(RunCommand("PATH=/nonexistent " + std::string(RELUME_BINARY) + " batch" + one + out + " --slurm"),
                  "sbatch: not found");
  ExpectUserError(RunRelume("batch" + one + out + " --only-failed"), "give no sessions");
  ExpectUserError(RunRelume("batch --out " + (dir / "never-ran").string() + " --only-failed"),
                  "no batch has run there yet");
  ExpectUserError(RunRelume("batch" + one + out + " --local 0"), "--local 0: give 1 or more");
  ExpectUserError(RunRelume("batch" + one + out + " --local-start spawn"), "--local-start: spawn not in {fork,exec}");
  ExpectUserError(RunRelume("batch" + one + out + " --slurm --time soon"), "not a Slurm time");
  ExpectUserError(RunRelume("batch" + one), "--out");
  // A folder of the user's is not taken over.
  fs::create_directories(dir / "mine");
  std::ofstream(dir / "mine" / "thesis.tex") << "x";
  ExpectUserError(RunRelume("batch" + one + " --out " + (dir / "mine").string()), "not a relume batch folder");
}

// A full disk: the batch stops with a message naming the file and what to do (run only where the
// test may mount a small tmpfs, i.e. as root with the capability; skipped with a message otherwise).
TEST_F(BatchCliTest, AFullDiskIsNamedWithWhatToDo) {
  const fs::path tiny = Field().parent_path() / "tiny-disk";
  fs::create_directories(tiny);
  if (RunCommand("mount -t tmpfs -o size=600k tmpfs " + tiny.string()).exit_code != 0) {
    GTEST_SKIP() << "cannot mount a 600 KiB tmpfs here (needs root and CAP_SYS_ADMIN)";
  }
  const testing::CliResult full = RunRelume("batch " + (Field() / "day0/session").string() + " --out " +
                                            (tiny / "batch").string() + " --local 1 --pipeline irm");
  RunCommand("umount " + tiny.string());
  ExpectUserError(full, "No space left on device (the disk is full: free space or choose another --out folder");
}

}  // namespace
}  // namespace relume::batch
