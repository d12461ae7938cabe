#include "batch/local_backend.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <map>
#include <opencv2/core/utility.hpp>
#include <thread>

#include "batch/subprocess.h"
#include "batch/task.h"
#include "core/error.h"
#include "core/parallel.h"

namespace relume::batch {

namespace {
namespace fs = std::filesystem;

// The forked worker: its output goes to the task's log (already open as log_fd), its loops get
// `threads`, it runs the task and ends with `relume batch-task`'s exit code (0 done, 1 failed, 2
// an error that stopped it). _exit, not exit: the copies of this process's objects (the batch's
// folder lock among them) must not run their destructors or flush the parent's buffers twice.
[[noreturn]] void RunForkedTask(int log_fd, int threads, const fs::path& plan_file, int index,
                                const std::string& attempt) {
  int code = 2;
  const int null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  if (::dup2(log_fd, STDOUT_FILENO) < 0 || ::dup2(log_fd, STDERR_FILENO) < 0 ||
      (null_fd >= 0 && ::dup2(null_fd, STDIN_FILENO) < 0)) {
    ::_exit(code);
  }
  ::close(log_fd);
  if (null_fd >= 0) ::close(null_fd);
  try {
    // What SpawnWithLog gives a started worker, for any program this one starts in turn.
    ::setenv("RELUME_THREADS", std::to_string(threads).c_str(), 1);
    SetDefaultThreads(threads);
    cv::setNumThreads(threads);
    const TaskRecord record = RunBatchTask(plan_file, index, attempt);
    code = record.state == TaskState::kDone ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "relume: error: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "relume: error: unknown\n";
  }
  std::cout.flush();
  std::cerr.flush();
  std::fflush(nullptr);
  ::_exit(code);
}

pid_t ForkWorker(const fs::path& log, int threads, const fs::path& plan_file, int index, const std::string& attempt) {
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError(log.string(), std::string("cannot open the task's log: ") + std::strerror(errno));
  // Whatever this process has buffered is written once, by this process, not by both.
  std::cout.flush();
  std::cerr.flush();
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) RunForkedTask(fd, threads, plan_file, index, attempt);
  const int error = errno;
  ::close(fd);
  if (pid < 0) throw IoError(log.string(), std::string("cannot start a worker (fork): ") + std::strerror(error));
  return pid;
}

}  // namespace

bool RunsOneThread() {
  std::error_code ec;
  int threads = 0;
  for (fs::directory_iterator it("/proc/self/task", ec), end; !ec && it != end; it.increment(ec)) ++threads;
  return !ec && threads == 1;
}

LocalStart EffectiveLocalStart(LocalStart start) {
  return start == LocalStart::kFork && !RunsOneThread() ? LocalStart::kExec : start;
}

LocalStart RunLocalTasks(const std::vector<int>& indices, int workers, LocalStart start,
                         const std::vector<std::string>& task_command, const fs::path& plan_file,
                         const std::string& attempt, const std::function<fs::path(int)>& log_of,
                         const std::function<void(int index, const std::string& how)>& on_end) {
  start = EffectiveLocalStart(start);
  // The workers share the CPUs: each task's parallel loops get its share (core/parallel.h),
  // not every CPU each.
  const int share = std::max(1, DefaultThreads() / std::max(1, workers));
  std::size_t next = 0;
  std::map<pid_t, int> running;  // pid -> task index
  while (next < indices.size() || !running.empty()) {
    while (next < indices.size() && static_cast<int>(running.size()) < workers) {
      const int index = indices[next++];
      pid_t pid = 0;
      if (start == LocalStart::kFork) {
        pid = ForkWorker(log_of(index), share, plan_file, index, attempt);
      } else {
        std::vector<std::string> argv = task_command;
        argv.push_back(plan_file.string());
        argv.push_back(std::to_string(index));
        argv.push_back(attempt);
        pid = SpawnWithLog(argv, log_of(index), {"RELUME_THREADS=" + std::to_string(share)});
      }
      running[pid] = index;
    }
    // Only our own children are waited for (never waitpid(-1): the caller may have others).
    bool ended = false;
    for (auto it = running.begin(); it != running.end();) {
      int status = 0;
      const pid_t pid = ::waitpid(it->first, &status, WNOHANG);
      if (pid == it->first || (pid < 0 && errno == ECHILD)) {
        const int index = it->second;
        it = running.erase(it);
        ended = true;
        on_end(index, pid < 0 ? "lost (not a child any more)" : DescribeWaitStatus(status));
      } else {
        ++it;
      }
    }
    // 5 ms: a worker ending waits at most that long for the next task (about 1 % of a tiny task).
    if (!ended) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return start;
}

}  // namespace relume::batch
