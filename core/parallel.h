// One parallel-for for the data-parallel loops of every layer (rows of an image, vertices of a
// mesh). Short-lived: threads are started and joined inside each call (no pool lives between
// calls), which costs tens of microseconds per call, nothing next to the loops it runs.
//
// Contract of ParallelFor(begin, end, body, threads, min_chunk):
//  - body(chunk_begin, chunk_end) is called on disjoint, contiguous, non-empty chunks that
//    together cover [begin, end) exactly once; nothing is called for an empty range. Chunks hold
//    max(min_chunk, about (end - begin) / (16 * threads)) indices (the last may hold fewer) and
//    are handed out in increasing order from an atomic counter, so that threads that meet slow
//    indices take fewer chunks. Which thread runs which chunk, and when, is not fixed: body must
//    give each index the same result whatever its chunk (write per index, or sum integers), which
//    keeps the callers' outputs bit-identical for any thread count.
//  - threads: how many threads run chunks (0 = DefaultThreads()), the calling
//    thread being one of them. No more than (end - begin) / min_chunk are used (at least one),
//    so that no thread is started for fewer than min_chunk indices. With one, body(begin, end)
//    runs once, inline, on the calling thread (ParallelThreads says how many a call will use).
//  - Exceptions: one thrown by body on any thread stops the handing out of further chunks (those
//    already running finish); once every thread has joined, the first exception caught is
//    rethrown on the calling thread. The others are dropped.
//  - begin > end, threads < 0 or min_chunk < 1 are bugs (RELUME_CHECK).
#pragma once

#include <cstdint>
#include <functional>

namespace relume {

// The threads a call with threads = 0 uses: the RELUME_THREADS environment variable when it is a
// positive number (what `relume batch` gives each of its workers), else SLURM_CPUS_PER_TASK (a
// Slurm task's share), else the CPUs this process may run on (its affinity mask, which
// taskset, cgroups' cpusets and schedulers set; std::thread::hardware_concurrency counts the
// machine's). Read once per process, unless SetDefaultThreads replaces it.
int DefaultThreads();

// Replaces what DefaultThreads() returns from now on (threads > 0), or goes back to what the
// environment and the affinity mask say (threads = 0). For a process that changes its share of
// the CPUs after it started: a worker that `relume batch --local N` forks to run one task gets
// the CPUs divided by N. Calls already running keep the threads they started with.
void SetDefaultThreads(int threads);

// How many threads (the caller's included) ParallelFor(begin, end, ..., threads, min_chunk) runs
// chunks on: min(threads or DefaultThreads(), (end - begin) / min_chunk), at least 1.
int ParallelThreads(std::int64_t begin, std::int64_t end, int threads = 0, std::int64_t min_chunk = 1);

void ParallelFor(std::int64_t begin, std::int64_t end,
                 const std::function<void(std::int64_t chunk_begin, std::int64_t chunk_end)>& body, int threads = 0,
                 std::int64_t min_chunk = 1);

// fn(i) for each i in [begin, end), with ParallelFor's chunks, threads and exceptions: for loops
// whose work per index needs no state per chunk. fn is called directly (it may be inlined); only
// the chunk goes through std::function.
template <typename Fn>
void ParallelForEach(std::int64_t begin, std::int64_t end, Fn&& fn, int threads = 0, std::int64_t min_chunk = 1) {
  ParallelFor(
      begin, end,
      [&fn](std::int64_t chunk_begin, std::int64_t chunk_end) {
        for (std::int64_t i = chunk_begin; i < chunk_end; ++i) fn(i);
      },
      threads, min_chunk);
}

}  // namespace relume
