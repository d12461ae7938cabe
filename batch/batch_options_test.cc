#include "batch/batch_options.h"

#include <gtest/gtest.h>

namespace relume::batch {
namespace {

BatchOptions Valid() {
  BatchOptions o;
  o.sessions = {"/data/s1", "/data/s2"};
  o.out_dir = "/tmp/out";
  o.task_command = {"/usr/bin/relume", "batch-task"};
  return o;
}

// IsValid's message, which must name the problem.
std::string Why(const BatchOptions& o) {
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  return why;
}

TEST(BatchOptionsTest, DefaultsWithSessionsOutAndCommandAreValid) {
  std::string why;
  EXPECT_TRUE(Valid().IsValid(&why)) << why;
  BatchOptions slurm = Valid();
  slurm.backend = Backend::kSlurm;
  slurm.slurm.time_limit = "1-02:30:00";
  slurm.slurm.extra_args = {"--qos=long"};
  EXPECT_TRUE(slurm.IsValid(&why)) << why;
}

TEST(BatchOptionsTest, MissingPiecesAreNamed) {
  BatchOptions o = Valid();
  o.out_dir.clear();
  EXPECT_NE(Why(o).find("--out"), std::string::npos);
  o = Valid();
  o.sessions.clear();
  EXPECT_NE(Why(o).find("no sessions"), std::string::npos);
  o = Valid();
  o.task_command.clear();
  EXPECT_NE(Why(o).find("batch-task"), std::string::npos);
  o = Valid();
  o.request.session_dir = "/x";
  EXPECT_NE(Why(o).find("per task"), std::string::npos);
  o = Valid();
  o.request.explain = true;
  EXPECT_NE(Why(o).find("--explain"), std::string::npos);
}

TEST(BatchOptionsTest, WorkerAndSlurmNumbersMustBeSensible) {
  BatchOptions o = Valid();
  o.local_workers = 0;
  EXPECT_NE(Why(o).find("--local 0"), std::string::npos);
  o = Valid();
  o.backend = Backend::kSlurm;
  o.slurm.cpus_per_task = 0;
  EXPECT_NE(Why(o).find("--cpus-per-task"), std::string::npos);
  o.slurm.cpus_per_task = 1;
  o.slurm.memory_per_task_mb = -5;
  EXPECT_NE(Why(o).find("--mem-per-task"), std::string::npos);
  o.slurm.memory_per_task_mb = 0;
  o.slurm.max_running_tasks = -1;
  EXPECT_NE(Why(o).find("--max-running"), std::string::npos);
  o.slurm.max_running_tasks = 0;
  o.slurm.poll_interval_s = 0;
  EXPECT_NE(Why(o).find("--poll"), std::string::npos);
  o.slurm.poll_interval_s = 1;
  o.slurm.time_limit = "two hours";
  EXPECT_NE(Why(o).find("not a Slurm time"), std::string::npos);
  o.slurm.time_limit = "";
  o.slurm.extra_args = {"--array=0-3"};
  EXPECT_NE(Why(o).find("relume's to set"), std::string::npos);
  // The local backend does not look at Slurm's options.
  o.backend = Backend::kLocal;
  EXPECT_TRUE(o.IsValid(nullptr));
}

TEST(BatchOptionsTest, OnlyFailedTakesNeitherSessionsNorPipelineOptions) {
  BatchOptions o = Valid();
  o.only_failed = true;
  EXPECT_NE(Why(o).find("give no sessions"), std::string::npos);
  o.sessions.clear();
  EXPECT_TRUE(o.IsValid(nullptr));
  o.request.settings.emplace("bins", std::string(1, '8'));
  EXPECT_NE(Why(o).find("own pipeline options"), std::string::npos);
  o.request.settings.clear();
  o.request.reuse = false;  // --force
  EXPECT_NE(Why(o).find("own pipeline options"), std::string::npos);
}

}  // namespace
}  // namespace relume::batch
