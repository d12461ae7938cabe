// The path policy and the folder lock (issue: hardening): every case a user or a damaged
// session can cause, each named after it.
#include "capture/path_policy.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/core.hpp>
#include <sstream>

#include "capture/folder_lock.h"
#include "capture/session.h"
#include "capture/session_check.h"
#include "capture/sqlite.h"
#include "core/error.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("path_policy_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A session with one still frame (frames/sim_cam/00000001_still.png).
fs::path MakeSession(const std::string& name) {
  const fs::path dir = FreshDir(name) / "session";
  SessionInfo info;
  info.name = name;
  info.site = Site::FromDegrees(37.97, 23.72, 150);
  info.created_utc = ParseIso8601("2026-06-21T06:00:00Z").utc;
  auto writer = SessionWriter::Create(dir, info);
  drivers::StillFrame frame;
  frame.device_id = "sim:cam";
  frame.image.pixels = cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
  frame.timing.host_utc = info.created_utc;
  writer->WriteStillFrame(frame);
  return dir;
}

void SetFramePath(const fs::path& session, const std::string& path) {
  Database db((session / kSessionDatabaseName).string(), Database::Mode::kReadWrite);
  db.Prepare("UPDATE frames SET file_path = ?").Bind(1, path).Run();
}

TEST(PathPolicyTest, SessionPathsStayInsideTheSession) {
  const fs::path dir = FreshDir("inside");
  fs::create_directories(dir / "frames" / "cam");
  EXPECT_FALSE(SessionPathProblem(dir, "frames/cam/1.png"));
  EXPECT_FALSE(SessionPathProblem(dir, "frames/cam/missing.png"));  // missing is the reader's to say
  EXPECT_NE(SessionPathProblem(dir, "/etc/passwd").value_or("").find("is absolute"), std::string::npos);
  EXPECT_NE(SessionPathProblem(dir, "../../etc/passwd").value_or("").find("climbs out"), std::string::npos);
  EXPECT_NE(SessionPathProblem(dir, "frames/../../x").value_or("").find("climbs out"), std::string::npos);
  EXPECT_NE(SessionPathProblem(dir, "").value_or("").find("empty"), std::string::npos);
  fs::create_directory_symlink("/tmp", dir / "frames" / "linked");
  EXPECT_NE(SessionPathProblem(dir, "frames/linked/x.png").value_or("").find("symbolic link (frames/linked)"),
            std::string::npos);
  EXPECT_THROW(SessionFilePath(dir, "/etc/passwd", "frame 1"), IoError);
}

TEST(PathPolicyTest, ReadRegularFileRefusesFifoDirectoryAndLinkWithoutBlocking) {
  const fs::path dir = FreshDir("regular");
  std::ofstream(dir / "file") << "bytes";
  EXPECT_EQ(ReadRegularFile(dir / "file").size(), 5u);
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  try {
    ReadRegularFile(dir / "fifo");  // would block forever with a plain open
    ADD_FAILURE() << "a FIFO was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("is a FIFO (named pipe), not a regular file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadRegularFile(dir), IoError);
  fs::create_symlink(dir / "file", dir / "link");
  try {
    ReadRegularFile(dir / "link");
    ADD_FAILURE() << "a link was followed";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("is a symbolic link"), std::string::npos) << e.what();
  }
  try {
    ReadRegularFile(dir / "absent");
    ADD_FAILURE();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("is missing"), std::string::npos) << e.what();
  }
}

TEST(PathPolicyTest, OutputEqualToAnInputOrInsideFramesIsRefused) {
  const fs::path session = MakeSession("outputs");
  const fs::path input = session.parent_path() / "in.png";
  std::ofstream(input) << "input";
  fs::create_symlink(input, session.parent_path() / "alias.png");
  EXPECT_THROW(CheckOutputFile(input, {input}, "--out"), InvalidArgumentError);
  EXPECT_THROW(CheckOutputFile(session.parent_path() / "alias.png", {input}, "--out"), InvalidArgumentError);
  EXPECT_NO_THROW(CheckOutputFile(session.parent_path() / "out.exr", {input}, "--out"));
  EXPECT_THROW(CheckOutputFile(session / "frames" / "sim_cam" / "x.exr", {}, "--out"), InvalidArgumentError);
  EXPECT_THROW(CheckOutputFile(session / kSessionDatabaseName, {}, "--out"), InvalidArgumentError);
  EXPECT_THROW(CheckOutputFolder(session / "frames" / "new", "--out"), InvalidArgumentError);
  EXPECT_THROW(CheckOutputFolder(session, "--out"), InvalidArgumentError);
  EXPECT_NO_THROW(CheckOutputFolder(session / "processed", "--out"));
  fs::path found;
  EXPECT_TRUE(IsInsideSessionData(session / "rig" / "a" / "b", &found));
  EXPECT_EQ(found, fs::canonical(session));
}

// Issue case 1: recover must not rename a link under frames/ onto the file it points at.
TEST(PathPolicyTest, RecoverLeavesASymlinkUnderFramesAndTheFileItNamesAlone) {
  const fs::path session = MakeSession("recover_link");
  const fs::path precious = session.parent_path() / "precious.txt";
  std::ofstream(precious) << "keep me";
  fs::create_symlink(precious, session / "frames" / "sim_cam" / "00000077_still.tiff");
  const RecoverReport report = RecoverSession(session);
  EXPECT_EQ(report.foreign_left, 1);
  EXPECT_EQ(report.orphans_kept, 0);
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(precious)));
  EXPECT_EQ(ReadText(precious), "keep me");
  EXPECT_TRUE(fs::is_symlink(session / "frames" / "sim_cam" / "00000077_still.tiff"));
  const VerifyReport verify = VerifySession(session);
  EXPECT_EQ(verify.foreign_entries, 1);
  EXPECT_FALSE(verify.ok());
}

TEST(PathPolicyTest, RecoverNeverOverwritesAnEarlierOrphan) {
  const fs::path session = MakeSession("orphans");
  std::ofstream(session / "frames" / "sim_cam" / "00000009_still.png") << "first";
  RecoverSession(session);
  std::ofstream(session / "frames" / "sim_cam" / "00000009_still.png") << "second";
  RecoverSession(session);
  EXPECT_EQ(ReadText(session / "orphans" / "sim_cam" / "00000009_still.png"), "first");
  EXPECT_EQ(ReadText(session / "orphans" / "sim_cam" / "00000009_still.png.1"), "second");
}

// Issue case 11: rows naming files outside the session are reported, never read.
TEST(PathPolicyTest, FrameRowsOutsideTheSessionAreNotRead) {
  for (const std::string& path : {std::string("../../etc/passwd"), std::string("/etc/passwd")}) {
    const fs::path session = MakeSession("outside");
    SetFramePath(session, path);
    const VerifyReport verify = VerifySession(session);
    EXPECT_EQ(verify.unsafe_paths, 1) << path;
    EXPECT_EQ(verify.checksum_mismatches, 0) << path;
    const SessionReader reader(session);
    try {
      reader.ReadFrameFile(reader.Frames().front());
      ADD_FAILURE() << path << " was read";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find("relume reads only files inside the session"), std::string::npos)
          << e.what();
    }
  }
}

// Issue case 10: a frame file that is a FIFO must not hang verify or the reader.
TEST(PathPolicyTest, FrameFileThatIsAFifoIsAProblemNotAHang) {
  const fs::path session = MakeSession("fifo");
  const fs::path file = session / "frames" / "sim_cam" / "00000001_still.png";
  fs::remove(file);
  ASSERT_EQ(::mkfifo(file.c_str(), 0600), 0);
  const VerifyReport verify = VerifySession(session);
  EXPECT_EQ(verify.unsafe_paths, 1);
  EXPECT_NE(verify.Summary().find("FIFO"), std::string::npos) << verify.Summary();
  const SessionReader reader(session);
  EXPECT_THROW(reader.LoadImage(reader.Frames().front()), IoError);
}

// Issue case 5: reading a 0-byte session.sqlite must not write a schema into it.
TEST(PathPolicyTest, EmptyDatabaseIsReportedAndLeftUntouched) {
  const fs::path dir = FreshDir("empty_db");
  std::ofstream(dir / kSessionDatabaseName).flush();
  try {
    SessionReader reader(dir);
    ADD_FAILURE() << "an empty file was read as a session";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("is not a relume session database"), std::string::npos) << e.what();
  }
  EXPECT_EQ(fs::file_size(dir / kSessionDatabaseName), 0u);
  EXPECT_THROW(VerifySession(dir), IoError);
  EXPECT_EQ(fs::file_size(dir / kSessionDatabaseName), 0u);
}

// Issue case 8.
TEST(PathPolicyTest, NonNumericSchemaVersionIsAClearError) {
  const fs::path session = MakeSession("schema");
  {
    Database db((session / kSessionDatabaseName).string(), Database::Mode::kReadWrite);
    db.Exec("UPDATE meta SET value = 'abc' WHERE key = 'schema_version'");
  }
  try {
    SessionReader reader(session);
    ADD_FAILURE();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("schema_version 'abc' is not a version number"), std::string::npos)
        << e.what();
  }
}

// Disk full while a session is created: the database has its tables but no session row. It
// recorded nothing; a new capture into the folder replaces it, and readers say what happened.
TEST(PathPolicyTest, UnfinishedCreationIsExplainedAndReplaced) {
  const fs::path dir = FreshDir("unfinished");
  {
    const fs::path session = MakeSession("unfinished_template");
    fs::copy_file(session / kSessionDatabaseName, dir / kSessionDatabaseName);
    Database db((dir / kSessionDatabaseName).string(), Database::Mode::kReadWrite);
    db.Exec("DELETE FROM frames");
    db.Exec("DELETE FROM devices");
    db.Exec("DELETE FROM session");
  }
  try {
    SessionReader reader(dir);
    ADD_FAILURE();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("never completely created"), std::string::npos) << e.what();
  }
  SessionInfo info;
  info.name = "again";
  info.site = Site::FromDegrees(37.97, 23.72, 150);
  EXPECT_NO_THROW(SessionWriter::Create(dir, info));
  EXPECT_EQ(SessionReader(dir).info().name, "again");
}

// Runs `work` in a child process; its exit code (0 = the child's expectations held).
int InChild(const std::function<int()>& work) {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(work());
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Issue case 4: a second writer is refused with a message naming the first.
TEST(FolderLockTest, ASecondProcessIsRefusedWhileTheFirstHoldsTheLock) {
  const fs::path session = MakeSession("lock");
  {
    auto writer = SessionWriter::Append(session);
    const FolderLock again = FolderLock::Acquire(session, "same process");  // shared within a process
    const int child = InChild([&] {
      try {
        SessionWriter::Append(session);
        return 1;
      } catch (const IoError& e) {
        const std::string message = e.what();
        return message.find("is in use by pid " + std::to_string(::getppid())) != std::string::npos ? 0 : 2;
      }
    });
    EXPECT_EQ(child, 0);
    EXPECT_EQ(InChild([&] {
                try {
                  RecoverSession(session);
                  return 1;
                } catch (const IoError&) {
                  return 0;
                }
              }),
              0);
  }
  // Released with its last holder: another process may write now.
  EXPECT_EQ(InChild([&] {
              try {
                SessionWriter::Append(session);
                return 0;
              } catch (const Error&) {
                return 1;
              }
            }),
            0);
}

}  // namespace
}  // namespace relume::capture
