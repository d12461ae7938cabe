#include "core/parallel.h"

#include <gtest/gtest.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace relume {
namespace {

struct Coverage {
  std::vector<int> calls_per_index;  // by index - begin
  int empty_chunks = 0;
  int out_of_range_chunks = 0;
  std::set<std::thread::id> thread_ids;
};

// Runs ParallelFor over [begin, end) and records every chunk it hands out.
Coverage RunAndRecord(std::int64_t begin, std::int64_t end, int threads, std::int64_t min_chunk) {
  Coverage out;
  std::vector<std::atomic<int>> calls(static_cast<std::size_t>(end - begin));
  std::atomic<int> empty{0}, out_of_range{0};
  std::mutex ids_mutex;
  ParallelFor(
      begin, end,
      [&](std::int64_t b, std::int64_t e) {
        if (b >= e) ++empty;
        if (b < begin || e > end) {
          ++out_of_range;
          return;
        }
        for (std::int64_t i = b; i < e; ++i) ++calls[static_cast<std::size_t>(i - begin)];
        const std::lock_guard<std::mutex> lock(ids_mutex);
        out.thread_ids.insert(std::this_thread::get_id());
      },
      threads, min_chunk);
  for (const std::atomic<int>& c : calls) out.calls_per_index.push_back(c.load());
  out.empty_chunks = empty;
  out.out_of_range_chunks = out_of_range;
  return out;
}

TEST(ParallelForTest, CoversEveryIndexExactlyOnce) {
  for (const std::int64_t begin : {std::int64_t{0}, std::int64_t{-37}, std::int64_t{1'000'000'007}}) {
    for (const std::int64_t count : {0, 1, 2, 3, 7, 16, 17, 100, 1000, 4097}) {
      for (const int threads : {0, 1, 2, 3, 8, 64}) {
        for (const std::int64_t min_chunk : {1, 3, 8, 1000}) {
          const Coverage c = RunAndRecord(begin, begin + count, threads, min_chunk);
          const std::string where = "begin " + std::to_string(begin) + ", count " + std::to_string(count) +
                                    ", threads " + std::to_string(threads) + ", min_chunk " + std::to_string(min_chunk);
          ASSERT_EQ(c.empty_chunks, 0) << where;
          ASSERT_EQ(c.out_of_range_chunks, 0) << where;
          for (std::size_t i = 0; i < c.calls_per_index.size(); ++i) {
            ASSERT_EQ(c.calls_per_index[i], 1) << where << ": index " << begin + static_cast<std::int64_t>(i);
          }
          EXPECT_LE(static_cast<int>(c.thread_ids.size()), ParallelThreads(begin, begin + count, threads, min_chunk))
              << where;
        }
      }
    }
  }
}

TEST(ParallelForTest, EmptyRangeCallsNothing) {
  int calls = 0;
  ParallelFor(
      5, 5, [&](std::int64_t, std::int64_t) { ++calls; }, 4);
  ParallelFor(
      5, 5, [&](std::int64_t, std::int64_t) { ++calls; }, 1);
  EXPECT_EQ(calls, 0);
}

TEST(ParallelForTest, OneElementIsOneInlineCall) {
  std::vector<std::pair<std::int64_t, std::int64_t>> chunks;
  std::thread::id ran_on;
  ParallelFor(
      41, 42,
      [&](std::int64_t b, std::int64_t e) {
        chunks.emplace_back(b, e);
        ran_on = std::this_thread::get_id();
      },
      8);
  ASSERT_EQ(chunks.size(), 1u);
  EXPECT_EQ(chunks[0], std::make_pair(std::int64_t{41}, std::int64_t{42}));
  EXPECT_EQ(ran_on, std::this_thread::get_id());
}

TEST(ParallelForTest, OneThreadRunsTheWholeRangeOnTheCallingThread) {
  std::vector<std::pair<std::int64_t, std::int64_t>> chunks;
  std::vector<std::thread::id> ids;
  ParallelFor(
      0, 10'000,
      [&](std::int64_t b, std::int64_t e) {
        chunks.emplace_back(b, e);
        ids.push_back(std::this_thread::get_id());
      },
      1);
  ASSERT_EQ(chunks.size(), 1u);
  EXPECT_EQ(chunks[0], std::make_pair(std::int64_t{0}, std::int64_t{10'000}));
  EXPECT_EQ(ids[0], std::this_thread::get_id());
}

TEST(ParallelForTest, ARangeSmallerThanTwoChunksRunsInline) {
  // 15 indices, at least 8 per thread: one thread, the caller's.
  EXPECT_EQ(ParallelThreads(0, 15, 4, 8), 1);
  std::set<std::thread::id> ids;
  ParallelFor(
      0, 15, [&](std::int64_t, std::int64_t) { ids.insert(std::this_thread::get_id()); }, 4, 8);
  EXPECT_EQ(ids, std::set<std::thread::id>{std::this_thread::get_id()});
}

TEST(ParallelForTest, ThreadCountIsLimitedByTheRangeAndMinChunk) {
  EXPECT_EQ(ParallelThreads(0, 100, 4, 8), 4);
  EXPECT_EQ(ParallelThreads(0, 20, 8, 8), 2);  // 20 / 8: no thread for fewer than 8 rows
  EXPECT_EQ(ParallelThreads(0, 5, 8, 8), 1);
  EXPECT_EQ(ParallelThreads(0, 0, 4, 1), 1);
  EXPECT_EQ(ParallelThreads(-10, 10, 64, 1), 20);
  EXPECT_EQ(ParallelThreads(0, 1'000'000, 0, 1), DefaultThreads());
}

// DefaultThreads is read once per process, so each case runs in a fresh one (threadsafe death
// tests re-run the binary): RELUME_THREADS wins over SLURM_CPUS_PER_TASK, which wins over the
// affinity mask; a malformed value is ignored.
TEST(ParallelForTest, DefaultThreadsFollowTheEnvironmentAndTheAffinityMask) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        setenv("RELUME_THREADS", "3", 1);
        setenv("SLURM_CPUS_PER_TASK", "5", 1);
        std::exit(DefaultThreads() == 3 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(
      {
        setenv("RELUME_THREADS", "many", 1);
        setenv("SLURM_CPUS_PER_TASK", "5", 1);
        std::exit(DefaultThreads() == 5 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(
      {
        unsetenv("RELUME_THREADS");
        unsetenv("SLURM_CPUS_PER_TASK");
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET(0, &one);
        if (sched_setaffinity(0, sizeof(one), &one) != 0) std::exit(2);
        std::exit(DefaultThreads() == 1 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

// A forked batch worker's share replaces the count, and 0 restores it; ParallelThreads (what
// ParallelFor with threads = 0 starts) follows it.
TEST(ParallelForTest, SetDefaultThreadsReplacesTheCountUntilReset) {
  const int before = DefaultThreads();
  SetDefaultThreads(before + 3);
  EXPECT_EQ(DefaultThreads(), before + 3);
  EXPECT_EQ(ParallelThreads(0, 1'000'000, 0, 1), before + 3);
  SetDefaultThreads(1);
  EXPECT_EQ(ParallelThreads(0, 1'000'000, 0, 1), 1);
  SetDefaultThreads(0);
  EXPECT_EQ(DefaultThreads(), before);
}

TEST(ParallelForTest, TwoThreadsRunChunksAtTheSameTime) {
  // Every chunk waits until two different threads are inside body at once: this returns only
  // if the second thread really runs beside the caller (a deadline keeps a failure from hanging).
  std::mutex m;
  std::condition_variable cv;
  std::set<std::thread::id> inside;
  bool met = false;
  ParallelFor(
      0, 64,
      [&](std::int64_t, std::int64_t) {
        std::unique_lock<std::mutex> lock(m);
        inside.insert(std::this_thread::get_id());
        if (inside.size() >= 2) met = true;
        cv.notify_all();
        cv.wait_for(lock, std::chrono::seconds(10), [&] { return met; });
      },
      2);
  EXPECT_TRUE(met);
}

TEST(ParallelForTest, AnExceptionIsRethrownOnTheCallerAfterAllThreadsJoined) {
  for (const int threads : {1, 2, 4}) {
    std::atomic<int> running{0};
    std::atomic<int> running_at_return{-1};
    try {
      ParallelFor(
          0, 1000,
          [&](std::int64_t b, std::int64_t e) {
            ++running;
            std::this_thread::sleep_for(std::chrono::microseconds(200));
            if (b <= 500 && 500 < e) {
              --running;
              throw std::runtime_error("index 500");
            }
            --running;
          },
          threads);
      ADD_FAILURE() << "no exception with " << threads << " threads";
    } catch (const std::runtime_error& e) {
      running_at_return = running.load();
      EXPECT_EQ(std::string(e.what()), "index 500");
    }
    EXPECT_EQ(running_at_return.load(), 0) << threads << " threads";
  }
}

TEST(ParallelForTest, OnlyOneOfManyExceptionsIsRethrownAndLaterChunksAreSkipped) {
  std::atomic<int> chunks_run{0};
  try {
    ParallelFor(
        0, 10'000,
        [&](std::int64_t b, std::int64_t) {
          ++chunks_run;
          throw std::out_of_range("chunk at " + std::to_string(b));
        },
        4, 1);
    ADD_FAILURE() << "no exception";
  } catch (const std::out_of_range& e) {
    EXPECT_EQ(std::string(e.what()).rfind("chunk at ", 0), 0u) << e.what();
  }
  // Each thread stops after its first throw: far fewer than the 64 chunks of 4 x 16.
  EXPECT_GE(chunks_run.load(), 1);
  EXPECT_LE(chunks_run.load(), 4);
}

TEST(ParallelForTest, ExceptionsOfOtherTypesKeepTheirType) {
  struct Custom {
    int code;
  };
  try {
    ParallelFor(
        0, 100,
        [](std::int64_t b, std::int64_t e) {
          if (b <= 99 && 99 < e) throw Custom{99};
        },
        3);
    ADD_FAILURE() << "no exception";
  } catch (const Custom& c) {
    EXPECT_EQ(c.code, 99);
  }
}

TEST(ParallelForTest, ForEachCallsEveryIndexOnce) {
  std::vector<std::atomic<int>> calls(1000);
  ParallelForEach(
      0, 1000, [&](std::int64_t i) { ++calls[static_cast<std::size_t>(i)]; }, 3, 7);
  for (std::size_t i = 0; i < calls.size(); ++i) EXPECT_EQ(calls[i].load(), 1) << i;
}

}  // namespace
}  // namespace relume
