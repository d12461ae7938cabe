// The atomic result handling of a batch task (task.h): a result is either published whole or
// not at all, and a stopped task's work folder is continued, never shown.
#include "batch/task.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "batch/plan.h"
#include "core/error.h"
#include "core/testing/temp_files.h"

namespace relume::batch {
namespace {
namespace fs = std::filesystem;

TEST(TaskResultTest, PublishedWholeOrNotAtAll) {
  const fs::path task = testing::FreshTempDir("task_test", "publish");
  const fs::path work = BeginResult(task);
  EXPECT_EQ(work, task / kWorkFolder);
  EXPECT_THROW(PublishResult(task), IoError);  // nothing to publish
  fs::create_directories(work / "stages" / "irm-0123");
  std::ofstream(work / "stages" / "irm-0123" / "stage.json") << "{}";
  std::ofstream(work / kResultRecordFile) << "{\"run\": 1}";
  EXPECT_FALSE(fs::exists(task / kResultFolder));  // still working: nothing published
  PublishResult(task);
  EXPECT_TRUE(fs::exists(task / kResultFolder / kResultRecordFile));
  EXPECT_FALSE(fs::exists(task / kWorkFolder));
  fs::remove_all(task);
}

TEST(TaskResultTest, ARerunUnpublishesKeepsStagesAndDropsTheOldRow) {
  const fs::path task = testing::FreshTempDir("task_test", "rerun");
  fs::create_directories(task / kResultFolder / "stages" / "irm-0123");
  std::ofstream(task / kResultFolder / "stages" / "irm-0123" / "stage.json") << "{}";
  std::ofstream(task / kResultFolder / kResultRecordFile) << "{\"run\": 1}";
  const fs::path work = BeginResult(task);
  EXPECT_FALSE(fs::exists(task / kResultFolder));                // not shown while it changes
  EXPECT_TRUE(fs::exists(work / "stages/irm-0123/stage.json"));  // the stage cache is kept
  EXPECT_FALSE(fs::exists(work / kResultRecordFile));            // no row of the earlier run
  // The task is killed here. The next run continues in the same work folder.
  EXPECT_EQ(BeginResult(task), work);
  EXPECT_TRUE(fs::exists(work / "stages/irm-0123/stage.json"));
  EXPECT_FALSE(fs::exists(task / kResultFolder));
  std::ofstream(work / kResultRecordFile) << "{\"run\": 2}";
  PublishResult(task);
  EXPECT_EQ(testing::ReadText(task / kResultFolder / kResultRecordFile), "{\"run\": 2}");
  fs::remove_all(task);
}

TEST(TaskResultTest, BothFoldersPresentKeepsTheCompleteOne) {
  const fs::path task = testing::FreshTempDir("task_test", "both");
  fs::create_directories(task / kResultFolder);
  std::ofstream(task / kResultFolder / "report.html") << "complete";
  fs::create_directories(task / kWorkFolder);
  std::ofstream(task / kWorkFolder / "half.txt") << "half";
  const fs::path work = BeginResult(task);
  EXPECT_EQ(testing::ReadText(work / "report.html"), "complete");
  EXPECT_FALSE(fs::exists(work / "half.txt"));
  fs::remove_all(task);
}

TEST(TaskRecordTest, RoundTripsAndAMissingRecordIsNotRun) {
  TaskRecord r;
  r.state = TaskState::kFailed;
  r.index = 3;
  r.attempt = "slurm-17";
  r.pid = 1234;
  r.seconds = 1.5;
  r.message = "disk full";
  const TaskRecord back = TaskRecordFromJson(TaskRecordToJson(r));
  EXPECT_EQ(back.state, TaskState::kFailed);
  EXPECT_EQ(back.index, 3);
  EXPECT_EQ(back.attempt, "slurm-17");
  EXPECT_EQ(back.pid, 1234);
  EXPECT_EQ(back.message, "disk full");
  EXPECT_EQ(ReadTaskRecord("/nonexistent/relume/task").state, TaskState::kNotRun);
  for (const TaskState s :
       {TaskState::kNotRun, TaskState::kQueued, TaskState::kRunning, TaskState::kDone, TaskState::kFailed}) {
    EXPECT_EQ(TaskStateFromName(TaskStateName(s)), s);
  }
}

// A task whose session cannot be processed records why and publishes nothing.
TEST(RunBatchTaskTest, AFolderThatIsNoSessionFailsWithItsReasonAndPublishesNothing) {
  const fs::path dir = testing::FreshTempDir("task_test", "nosession");
  fs::create_directories(dir / "fake");
  std::ofstream(dir / "fake" / "session.sqlite") << "not a database";
  pipeline::PipelineRequest request;
  request.pipeline = "radiance";
  const fs::path plan = WritePlan(MakePlan({dir / "fake"}, request), dir / "batch");
  const TaskRecord record = RunBatchTask(plan, 0, "local-test");
  EXPECT_EQ(record.state, TaskState::kFailed);
  EXPECT_FALSE(record.message.empty());
  const fs::path task = dir / "batch" / SessionFolderName(fs::weakly_canonical(dir / "fake"));
  EXPECT_EQ(ReadTaskRecord(task).state, TaskState::kFailed);
  EXPECT_EQ(ReadTaskRecord(task).attempt, "local-test");
  EXPECT_FALSE(fs::exists(task / kResultFolder));
  EXPECT_THROW(RunBatchTask(plan, 5, "local-test"), InvalidArgumentError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::batch
