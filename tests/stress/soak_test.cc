// The soak (issue: hardening): a simulated day of capture at the building site, a bracket every
// 2 minutes day and night, with a busy camera, time-outs, damaged transfers, an unplug, lost
// RGB-D frames, slow storage and, late in the evening, a full disk
// (tests/data/rigs/sim-soak.yaml), while `relume process` reads the growing session beside it.
// The capture must run until the disk is full and stop there with the disk-full message; after
// `recover` every acknowledged frame must verify; processing must succeed beside the capture and
// after it; the recorder's memory must stay flat.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;

// Resident memory of a process in KiB (VmRSS), or -1 when it has gone.
long RssKiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      long kib = -1;
      status >> kib;
      return kib;
    }
    status.ignore(1 << 12, '\n');
  }
  return -1;
}

long Median(std::vector<long> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(values.size() / 2), values.end());
  return values[values.size() / 2];
}

TEST(SoakTest, ASimulatedDayWithFaultsAFullDiskAndProcessingBeside) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "the soak measures memory, which ASan's quarantine and shadow make meaningless; it runs in the "
                  "Release build";
#endif
  const fs::path root = testing::FreshTempDir("soak", "day");
  const fs::path session = root / "session";
  const std::string rig = std::string(RELUME_SOURCE_DIR) + "/tests/data/rigs/sim-soak.yaml";
  const pid_t capture = ::fork();
  if (capture == 0) {
    const std::string log = (root / "capture.log").string();
    ::execl("/bin/sh", "sh", "-c",
            (std::string("exec ") + RELUME_BINARY + " capture --rig " + rig + " --out " + session.string() +
             " --no-progress > " + log + " 2>&1")
                .c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ASSERT_GT(capture, 0);

  // Processing beside the capture, as often as it can, into its own folder.
  std::atomic<bool> capturing = true;
  std::atomic<int> runs = 0, runs_ok = 0;
  std::string last_failure;
  std::thread processing([&] {
    while (capturing) {
      if (!fs::exists(session / "session.sqlite")) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        continue;
      }
      const auto r = testing::RunRelume("process " + session.string() + " --pipeline radiance --out " +
                                        (root / "processed").string());
      ++runs;
      if (r.exit_code == 0) {
        ++runs_ok;
      } else {
        last_failure = r.output;
      }
    }
  });

  std::vector<long> rss;  // every 100 ms while the capture runs
  int status = 0;
  const auto start = std::chrono::steady_clock::now();
  while (::waitpid(capture, &status, WNOHANG) == 0) {
    const long kib = RssKiB(capture);
    if (kib > 0) rss.push_back(kib);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  capturing = false;
  processing.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::ifstream log_file(root / "capture.log");
  std::ostringstream log_text;
  log_text << log_file.rdbuf();
  const std::string log = log_text.str();
  // Exit 3: the capture stopped on a storage failure (apps/relume/capture_command.cc).
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3) << log;
  EXPECT_NE(log.find("No space left on device"), std::string::npos) << log;
  EXPECT_NE(log.find("frames already acknowledged are safe"), std::string::npos) << log;

  const auto recover = testing::RunRelume("session recover " + session.string());
  EXPECT_EQ(recover.exit_code, 0) << recover.output;
  const auto verify = testing::RunRelume("session verify " + session.string());
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  const auto info = testing::RunRelume("session info " + session.string());
  EXPECT_NE(info.output.find("reconnected"), std::string::npos) << "the unplug was not exercised\n" << info.output;
  EXPECT_NE(info.output.find("retry"), std::string::npos) << "no retried fault\n" << info.output;
  // The disk fills at 14 MiB, after about 22 of the 24 hours: most of the day was recorded.
  const std::size_t at = info.output.find("frames        ");
  ASSERT_NE(at, std::string::npos) << info.output;
  EXPECT_GT(std::stol(info.output.substr(at + 14)), 3000) << info.output;

  EXPECT_GE(runs_ok.load(), 1) << runs.load() << " runs beside the capture; last failure:\n" << last_failure;
  const auto after =
      testing::RunRelume("process " + session.string() + " --pipeline radiance --out " + (root / "processed").string());
  EXPECT_EQ(after.exit_code, 0) << after.output;

  // Flat memory: the recorder's resident set in the last third of the day against the second
  // third (the first third holds start-up and the first allocations of every path).
  ASSERT_GE(rss.size(), 30u) << "the capture ran too briefly to judge its memory";
  const std::size_t third = rss.size() / 3;
  const long middle = Median({rss.begin() + static_cast<long>(third), rss.begin() + static_cast<long>(2 * third)});
  const long last = Median({rss.begin() + static_cast<long>(2 * third), rss.end()});
  const long peak = *std::max_element(rss.begin(), rss.end());
  std::printf(
      "soak: %.0f s, %d processing runs beside (%d ok), recorder RSS median %ld KiB (second third) -> %ld "
      "KiB (last third), peak %ld KiB, %zu samples\n",
      seconds, runs.load(), runs_ok.load(), middle, last, peak, rss.size());
  ::testing::Test::RecordProperty("rss_middle_kib", static_cast<int>(middle));
  ::testing::Test::RecordProperty("rss_last_kib", static_cast<int>(last));
  EXPECT_LE(last, middle + middle / 10 + 4096) << "the recorder's memory grows over the day";
}

}  // namespace
}  // namespace relume
