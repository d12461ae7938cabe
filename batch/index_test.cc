#include "batch/index.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

namespace relume::batch {
namespace {
namespace fs = std::filesystem;

BatchSummary TwoTasks() {
  BatchSummary s;
  s.out_dir = "/data/batch";
  s.backend = "slurm";
  s.job_id = "42";
  TaskOutcome done;
  done.index = 0;
  done.session = "/field/day, one/session";
  done.folder = "sessions/session-abc";
  done.state = TaskState::kDone;
  done.seconds = 2.5;
  done.log = "logs/slurm-42_0.log";
  done.report = "sessions/session-abc/result/report.html";
  done.pipelines = {{"irm", "relit vs truth: lit 0.2 %", "", {{"relit vs truth, lit", "0.20", "%"}}},
                    {"sh", "", "no RGB-D frames", {}}};
  TaskOutcome failed;
  failed.index = 1;
  failed.session = "/field/day2/session";
  failed.folder = "sessions/session-def";
  failed.state = TaskState::kFailed;
  failed.message = "ended without a result (Slurm: CANCELLED, while running)";
  failed.log = "logs/slurm-42_1.log";
  s.tasks = {done, failed};
  return s;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(IndexTest, CsvHasARowPerTaskWithFiguresAsColumnsAndQuotesCommas) {
  const std::vector<std::string> lines = Lines(IndexCsv(TwoTasks()));
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(
      lines[0],
      "task,session,state,seconds,report,log,message,irm: headline,sh: headline,\"irm: relit vs truth, lit [%]\"");
  EXPECT_EQ(lines[1],
            "0,\"/field/day, one/session\",done,2.50,sessions/session-abc/result/report.html,logs/slurm-42_0.log,,"
            "relit vs truth: lit 0.2 %,not run: no RGB-D frames,0.20");
  EXPECT_EQ(lines[2],
            "1,/field/day2/session,failed,0.00,,logs/slurm-42_1.log,"
            "\"ended without a result (Slurm: CANCELLED, while running)\",,,");
}

TEST(IndexTest, HtmlLinksReportsListsFailedTasksWithLogsAndEscapes) {
  BatchSummary s = TwoTasks();
  s.tasks[1].message = "bad <frame> & more";
  const std::string html = IndexHtml(s);
  EXPECT_NE(html.find("data-tasks=\"2\" data-done=\"1\" data-failed=\"1\""), std::string::npos);
  EXPECT_NE(html.find("<a href=\"sessions/session-abc/result/report.html\">report</a>"), std::string::npos);
  EXPECT_NE(html.find("<a href=\"logs/slurm-42_1.log\">logs/slurm-42_1.log</a>"), std::string::npos);
  EXPECT_NE(html.find("bad &lt;frame&gt; &amp; more"), std::string::npos);
  EXPECT_NE(html.find("relume batch --out /data/batch --only-failed"), std::string::npos);
  EXPECT_NE(html.find("relit vs truth: lit 0.2 %"), std::string::npos);
  EXPECT_NE(html.find("Slurm job 42"), std::string::npos);
  // Nothing failed: no failed table.
  s.tasks.pop_back();
  EXPECT_EQ(IndexHtml(s).find("id=\"failed\""), std::string::npos);
}

TEST(IndexTest, CountsAndBriefReportNameUnfinishedTasks) {
  BatchSummary s = TwoTasks();
  TaskOutcome never;
  never.index = 2;
  s.tasks.push_back(never);
  TaskOutcome running;
  running.index = 3;
  running.state = TaskState::kRunning;
  s.tasks.push_back(running);
  EXPECT_EQ(s.Count(TaskState::kDone), 1);
  EXPECT_EQ(s.Unfinished(), (std::vector<int>{1, 2}));
  EXPECT_FALSE(s.AllDone());
  EXPECT_EQ(s.BriefReport(), "4 session(s): 1 done, 1 failed, 1 running, 1 not run (tasks 1,2)");
}

TEST(IndexTest, WriteIndexWritesBothFilesWhole) {
  BatchSummary s = TwoTasks();
  s.out_dir = fs::temp_directory_path() / ("relume_index_test_" + std::to_string(::getpid()));
  fs::create_directories(s.out_dir);
  WriteIndex(s);
  EXPECT_EQ(s.index_csv, s.out_dir / "index.csv");
  std::ifstream csv(s.index_csv);
  std::stringstream text;
  text << csv.rdbuf();
  EXPECT_EQ(text.str(), IndexCsv(s));
  EXPECT_TRUE(fs::exists(s.out_dir / "index.html"));
  for (const auto& e : fs::directory_iterator(s.out_dir)) EXPECT_NE(e.path().extension(), ".tmp") << e.path();
  fs::remove_all(s.out_dir);
}

}  // namespace
}  // namespace relume::batch
