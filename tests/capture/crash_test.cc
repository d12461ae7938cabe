// Kills `relume capture` with SIGKILL at random moments, then recovers and verifies: every
// acknowledged frame must be present with a matching checksum, and nothing else may remain
// inconsistent.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <random>
#include <thread>

#include "capture/durable_file.h"
#include "capture/session.h"
#include "capture/session_check.h"

extern char** environ;

namespace relume {
namespace {

namespace fs = std::filesystem;

pid_t Spawn(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

TEST(CrashTest, SigkillAtRandomMomentsLosesNoAcknowledgedFrame) {
  std::mt19937 rng(20261122);
  std::uniform_int_distribution<int> delay_ms(500, 4000);
  int sessions_with_frames = 0;
  std::int64_t frames_total = 0;
  // Until four sessions had frames when killed (or 12 rounds: slow sanitizer builds).
  for (int round = 0; round < 12 && sessions_with_frames < 4; ++round) {
    const fs::path dir = fs::path(::testing::TempDir()) / ("crash_" + std::to_string(round));
    fs::remove_all(dir);
    const pid_t pid = Spawn(
        {RELUME_BINARY, "capture", "--rig", "tests/data/rigs/sim-kill.yaml", "--out", dir.string(), "--no-progress"});
    ASSERT_GT(pid, 0);
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    ASSERT_EQ(kill(pid, SIGKILL), 0);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the capture ended before it was killed (round " << round << ")";
    if (!fs::exists(dir / capture::kSessionDatabaseName)) continue;  // killed before the session existed

    // The rows committed before the kill: each is an acknowledged frame.
    std::vector<capture::FrameRecord> acknowledged = capture::SessionReader(dir).Frames();
    const capture::RecoverReport recovered = capture::RecoverSession(dir);
    const capture::VerifyReport report = capture::VerifySession(dir);
    EXPECT_TRUE(report.ok()) << "round " << round << ": " << report.Summary() << "\n" << recovered.Summary();
    const std::vector<capture::FrameRecord> after = capture::SessionReader(dir).Frames();
    ASSERT_EQ(after.size(), acknowledged.size());
    for (std::size_t i = 0; i < after.size(); ++i) {
      EXPECT_EQ(after[i].sha256, acknowledged[i].sha256);
      EXPECT_EQ(capture::Sha256HexOfFile(dir / after[i].file_path), after[i].sha256);
    }
    sessions_with_frames += acknowledged.empty() ? 0 : 1;
    frames_total += static_cast<std::int64_t>(acknowledged.size());
    std::printf("round %d: killed after %zu acknowledged frames; %s\n", round, acknowledged.size(),
                recovered.Summary().substr(0, 120).c_str());
  }
  EXPECT_GE(sessions_with_frames, 2) << "the kills came too early to test anything";
  std::printf("%d sessions with frames, %lld acknowledged frames, all intact after recover\n", sessions_with_frames,
              static_cast<long long>(frames_total));
}

}  // namespace
}  // namespace relume
