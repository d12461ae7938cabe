#include "batch/plan.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "batch/slurm_backend.h"
#include "core/error.h"
#include "core/testing/temp_files.h"

namespace relume::batch {
namespace {
namespace fs = std::filesystem;

// A folder that looks like a session to the planner (it holds session.sqlite).
void FakeSession(const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream(dir / "session.sqlite") << "";
}

template <typename Fn>
std::string ErrorOf(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(PlanTest, FolderNamesDifferForAlikeNamesAndAreStable) {
  const std::string a = SessionFolderName("/field/day1/session");
  const std::string b = SessionFolderName("/field/day2/session");
  EXPECT_NE(a, b);
  EXPECT_EQ(a, SessionFolderName("/field/day1/session"));
  EXPECT_EQ(a.rfind("sessions/session-", 0), 0u) << a;
  EXPECT_EQ(a.size(), std::string("sessions/session-").size() + 12);
  // Characters that would need quoting anywhere become '_'; a hidden name is not hidden.
  EXPECT_EQ(SessionFolderName("/x/my day $1").substr(0, 19), "sessions/my_day__1-");
  EXPECT_EQ(SessionFolderName("/x/.hidden").substr(0, 23), "sessions/session.hidden");
}

TEST(PlanTest, GlobsAndListFilesExpandInOrderWithoutDuplicates) {
  const fs::path dir = testing::FreshTempDir("plan_test", "expand");
  for (const char* name : {"a", "b", "c"}) FakeSession(dir / "field" / name / "session");
  {
    std::ofstream list(dir / "list.txt");
    list << "# the field season\n\n  field/c/session  \nfield/a/session\n";
  }
  const std::vector<fs::path> sessions =
      ExpandSessions({(dir / "field/*/session").string()}, std::optional<fs::path>(dir / "list.txt"));
  ASSERT_EQ(sessions.size(), 3u);
  EXPECT_EQ(sessions[0], fs::canonical(dir / "field/a/session"));
  EXPECT_EQ(sessions[2], fs::canonical(dir / "field/c/session"));
  fs::remove_all(dir);
}

TEST(PlanTest, BadPatternsAndNonSessionsAreNamed) {
  const fs::path dir = testing::FreshTempDir("plan_test", "bad");
  FakeSession(dir / "good");
  fs::create_directories(dir / "notes");
  EXPECT_NE(ErrorOf([&] { ExpandSessions({(dir / "nothing*").string()}, std::nullopt); }).find("matches nothing"),
            std::string::npos);
  const std::string not_session = ErrorOf([&] { ExpandSessions({(dir / "*").string()}, std::nullopt); });
  EXPECT_NE(not_session.find("notes is not a relume session (no session.sqlite)"), std::string::npos) << not_session;
  EXPECT_NE(ErrorOf([&] { ExpandSessions({(dir / "missing").string()}, std::nullopt); }).find("does not exist"),
            std::string::npos);
  std::ofstream(dir / "list.txt") << "good\nnotes\n";
  const std::string line = ErrorOf([&] { ExpandSessions({}, std::optional<fs::path>(dir / "list.txt")); });
  EXPECT_NE(line.find("list.txt:2"), std::string::npos) << line;
  EXPECT_NE(ErrorOf([&] { ExpandSessions({}, std::optional<fs::path>(dir / "nolist.txt")); }).find("cannot read"),
            std::string::npos);
  fs::remove_all(dir);
}

TEST(PlanTest, PlansRoundTripAndAnIdenticalPlanIsTheSameFile) {
  const fs::path dir = testing::FreshTempDir("plan_test", "roundtrip");
  pipeline::PipelineRequest request;
  request.pipeline = "irm";
  request.source = "bracket:1";
  request.settings["bins"] = "16";
  request.reuse = false;
  const BatchPlan plan = MakePlan({"/f/a/session", "/f/b/session"}, request);
  const fs::path file = WritePlan(plan, dir);
  EXPECT_EQ(file, WritePlan(plan, dir));
  const BatchPlan read = ReadPlan(file);
  ASSERT_EQ(read.tasks.size(), 2u);
  EXPECT_EQ(read.tasks[1].index, 1);
  EXPECT_EQ(read.tasks[1].session, fs::path("/f/b/session"));
  EXPECT_EQ(read.tasks[1].folder, SessionFolderName("/f/b/session"));
  EXPECT_EQ(read.request.pipeline, "irm");
  EXPECT_EQ(read.request.source, std::optional<std::string>("bracket:1"));
  EXPECT_FALSE(read.request.target.has_value());
  EXPECT_EQ(read.request.settings.at("bins"), "16");
  EXPECT_FALSE(read.request.reuse);
  EXPECT_THROW(PlanFromJson(nlohmann::json{{"format", "other"}}, "x.json"), InvalidArgumentError);
  fs::remove_all(dir);
}

TEST(SlurmBackendTest, ArraySpecCollapsesRangesAndAddsTheThrottle) {
  EXPECT_EQ(ArraySpec({0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, 2), "0-9%2");
  EXPECT_EQ(ArraySpec({5}, 0), "5");
  EXPECT_EQ(ArraySpec({0, 1, 3, 7, 8, 10}, 0), "0-1,3,7-8,10");
}

TEST(SlurmBackendTest, JobScriptAsksForTheResourcesAndQuotesPaths) {
  SlurmOptions slurm;
  slurm.partition = "short";
  slurm.time_limit = "0:30:00";
  slurm.cpus_per_task = 4;
  slurm.memory_per_task_mb = 8000;
  const std::string script =
      JobScript(slurm, {"/opt/relume/bin/relume", "batch-task"}, "/data/it's/plans/plan-1.json", "/data/logs", "rb");
  EXPECT_EQ(script.rfind("#!/bin/bash\n", 0), 0u);
  for (const char* line : {"#SBATCH --partition=short\n", "#SBATCH --time=0:30:00\n", "#SBATCH --cpus-per-task=4\n",
                           "#SBATCH --mem=8000M\n", "#SBATCH --output=/data/logs/slurm-%A_%a.log\n"}) {
    EXPECT_NE(script.find(line), std::string::npos) << line << " in\n" << script;
  }
  EXPECT_NE(script.find("exec '/opt/relume/bin/relume' 'batch-task' '/data/it'\\''s/plans/plan-1.json' "
                        "\"${SLURM_ARRAY_TASK_ID}\" \"slurm-${SLURM_ARRAY_JOB_ID}\"\n"),
            std::string::npos)
      << script;
  EXPECT_EQ(script.find("--account"), std::string::npos);
}

TEST(SlurmBackendTest, ActiveStates) {
  EXPECT_TRUE(IsActiveSlurmState("PENDING"));
  EXPECT_TRUE(IsActiveSlurmState("RUNNING"));
  EXPECT_FALSE(IsActiveSlurmState("COMPLETED"));
  EXPECT_FALSE(IsActiveSlurmState("CANCELLED"));
  EXPECT_FALSE(IsActiveSlurmState("OUT_OF_MEMORY"));
}

}  // namespace
}  // namespace relume::batch
