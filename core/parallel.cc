#include "core/parallel.h"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

#include "core/error.h"

namespace relume {

namespace {
// Chunks per thread: enough that a thread meeting slow indices (a row of sky next to a row of
// inter-reflections) hands the rest to the others; few enough that the counter and the calls
// through std::function cost nothing next to the work.
constexpr std::int64_t kChunksPerThread = 16;
}  // namespace

namespace {

// A positive whole number from the environment, or 0.
int ThreadsFromEnvironment(const char* name) {
  const char* text = std::getenv(name);
  if (text == nullptr) return 0;
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  return end != text && *end == '\0' && value > 0 && value <= 4096 ? static_cast<int>(value) : 0;
}

int CountDefaultThreads() {
  if (const int n = ThreadsFromEnvironment("RELUME_THREADS")) return n;
  if (const int n = ThreadsFromEnvironment("SLURM_CPUS_PER_TASK")) return n;
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (sched_getaffinity(0, sizeof(mask), &mask) == 0 && CPU_COUNT(&mask) > 0) return CPU_COUNT(&mask);
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

// SetDefaultThreads' value; 0: none.
std::atomic<int> default_threads_override{0};

}  // namespace

int DefaultThreads() {
  static const int threads = CountDefaultThreads();
  const int override_threads = default_threads_override.load(std::memory_order_relaxed);
  return override_threads > 0 ? override_threads : threads;
}

void SetDefaultThreads(int threads) {
  RELUME_CHECK(threads >= 0);
  default_threads_override.store(threads, std::memory_order_relaxed);
}

int ParallelThreads(std::int64_t begin, std::int64_t end, int threads, std::int64_t min_chunk) {
  RELUME_CHECK(begin <= end);
  RELUME_CHECK(threads >= 0);
  RELUME_CHECK(min_chunk >= 1);
  if (threads == 0) threads = DefaultThreads();
  return static_cast<int>(std::clamp<std::int64_t>((end - begin) / min_chunk, 1, threads));
}

void ParallelFor(std::int64_t begin, std::int64_t end,
                 const std::function<void(std::int64_t chunk_begin, std::int64_t chunk_end)>& body, int threads,
                 std::int64_t min_chunk) {
  const int workers = ParallelThreads(begin, end, threads, min_chunk);
  if (begin == end) return;
  if (workers == 1) {
    body(begin, end);
    return;
  }
  const std::int64_t count = end - begin;
  const std::int64_t per_chunk =
      std::max(min_chunk, (count + kChunksPerThread * workers - 1) / (kChunksPerThread * workers));
  const std::int64_t chunks = (count + per_chunk - 1) / per_chunk;
  // Chunk numbers, not indices, are counted: the counter passes `chunks` by at most the number
  // of threads, so it cannot overflow however close `end` is to the largest int64.
  std::atomic<std::int64_t> next_chunk{0};
  std::atomic<bool> failed{false};
  std::mutex first_error_mutex;
  std::exception_ptr first_error;
  auto run = [&]() noexcept {
    try {
      while (!failed.load(std::memory_order_relaxed)) {
        const std::int64_t k = next_chunk.fetch_add(1, std::memory_order_relaxed);
        if (k >= chunks) break;
        const std::int64_t chunk_begin = begin + k * per_chunk;
        body(chunk_begin, chunk_begin + std::min(per_chunk, end - chunk_begin));
      }
    } catch (...) {
      const std::lock_guard<std::mutex> lock(first_error_mutex);
      if (!first_error) first_error = std::current_exception();
      failed.store(true, std::memory_order_relaxed);
    }
  };
  std::vector<std::thread> helpers;
  helpers.reserve(static_cast<std::size_t>(workers - 1));
  for (int i = 1; i < workers; ++i) {
    try {
      helpers.emplace_back(run);
    } catch (const std::system_error&) {
      break;  // no thread to be had: the threads already running (the caller's at least) do all
    }
  }
  run();
  for (std::thread& helper : helpers) helper.join();
  if (first_error) std::rethrow_exception(first_error);
}

}  // namespace relume
