// How the local backend starts its workers (local_backend.h): forked from a process that runs one
// thread, started as the task command otherwise, each with its output in its own log.
#include "batch/local_backend.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "core/testing/temp_files.h"

namespace relume::batch {
namespace {
namespace fs = std::filesystem;

// A thread that lives until the object ends: the process runs more than one thread meanwhile.
class SecondThread {
 public:
  SecondThread()
      : thread_([this] {
          std::unique_lock<std::mutex> lock(m_);
          cv_.wait(lock, [this] { return done_; });
        }) {}
  ~SecondThread() {
    {
      std::lock_guard<std::mutex> lock(m_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

// The task command: a shell that prints what the backend gave it (plan, index, attempt) and the
// share of the CPUs in its environment, and fails task 1.
const std::vector<std::string> kEchoCommand = {
    "/bin/sh", "-c", "echo \"exec $1 $2 $3 threads=$RELUME_THREADS\"; test \"$2\" != 1", "sh"};

TEST(LocalBackendTest, AProcessWithThreadsStartsTheTaskCommandInstead) {
  const fs::path dir = testing::FreshTempDir("local_backend_test", "exec");
  std::map<int, std::string> ends;
  LocalStart used = LocalStart::kFork;
  {
    const SecondThread other;
    EXPECT_FALSE(RunsOneThread());
    used = RunLocalTasks(
        {0, 1, 2}, 2, LocalStart::kFork, kEchoCommand, dir / "plan.json", "local-test",
        [&](int i) { return dir / ("task" + std::to_string(i) + ".log"); },
        [&](int i, const std::string& how) { ends[i] = how; });
  }
  EXPECT_EQ(used, LocalStart::kExec);
  ASSERT_EQ(ends.size(), 3u);
  EXPECT_EQ(ends[0], "exit code 0");
  EXPECT_EQ(ends[1], "exit code 1");
  EXPECT_EQ(ends[2], "exit code 0");
  EXPECT_NE(
      testing::ReadText(dir / "task2.log").find("exec " + (dir / "plan.json").string() + " 2 local-test threads="),
      std::string::npos)
      << testing::ReadText(dir / "task2.log");
  fs::remove_all(dir);
}

// Two tasks of a plan that does not exist, on two forked workers: 0 when both were forked and
// ended with exit code 2; 3 when this process runs more than one thread.
int ForkTwoFailingTasks(const fs::path& dir) {
  if (!RunsOneThread()) return 3;
  std::map<int, std::string> ends;
  std::cout << "buffered in the parent";  // no newline, no flush
  const LocalStart used = RunLocalTasks(
      {0, 1}, 2, LocalStart::kFork, {"/nonexistent/relume", "batch-task"}, dir / "missing-plan.json", "local-test",
      [&](int i) { return dir / ("task" + std::to_string(i) + ".log"); },
      [&](int i, const std::string& how) { ends[i] = how; });
  const bool ok = used == LocalStart::kFork && ends.size() == 2 && ends[0] == "exit code 2" && ends[1] == "exit code 2";
  return ok ? 0 : 1;
}

// Forked workers run RunBatchTask in a copy of this process. Run in a fresh process (the
// threadsafe death-test style re-runs this binary for the statement) so that it has one thread:
// a plan file that does not exist stops each task with the error in its own log and exit code 2,
// and nothing the parent had buffered is written twice.
TEST(LocalBackendTest, AProcessWithOneThreadForksItsWorkers) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  // The death test's process runs this test again from its start: it finds the folder here.
  const char* const kDirVariable = "RELUME_LOCAL_BACKEND_TEST_DIR";
  const fs::path dir = std::getenv(kDirVariable) != nullptr ? fs::path(std::getenv(kDirVariable))
                                                            : testing::FreshTempDir("local_backend_test", "fork");
  ::setenv(kDirVariable, dir.c_str(), 1);
  EXPECT_EXIT(std::_Exit(ForkTwoFailingTasks(dir)), ::testing::ExitedWithCode(0), "");
  for (const int i : {0, 1}) {
    const std::string log = testing::ReadText(dir / ("task" + std::to_string(i) + ".log"));
    EXPECT_NE(log.find("relume: error: "), std::string::npos) << log;
    EXPECT_NE(log.find("missing-plan.json"), std::string::npos) << log;
    EXPECT_EQ(log.find("buffered in the parent"), std::string::npos) << log;
  }
  ::unsetenv(kDirVariable);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::batch
