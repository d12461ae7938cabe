#include "batch/local_backend.h"

#include <sys/wait.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <map>
#include <thread>

#include "batch/subprocess.h"
#include "core/parallel.h"

namespace relume::batch {

void RunLocalTasks(const std::vector<int>& indices, int workers, const std::vector<std::string>& task_command,
                   const std::filesystem::path& plan_file, const std::string& attempt,
                   const std::function<std::filesystem::path(int)>& log_of,
                   const std::function<void(int index, const std::string& how)>& on_end) {
  std::size_t next = 0;
  std::map<pid_t, int> running;  // pid -> task index
  while (next < indices.size() || !running.empty()) {
    while (next < indices.size() && static_cast<int>(running.size()) < workers) {
      const int index = indices[next++];
      std::vector<std::string> argv = task_command;
      argv.push_back(plan_file.string());
      argv.push_back(std::to_string(index));
      argv.push_back(attempt);
      // The workers share the CPUs: each task's parallel loops get its share (core/parallel.h),
      // not every CPU each (two workers on two cores ran 0.67x of one after another, not 0.5x).
      const int share = std::max(1, DefaultThreads() / std::max(1, workers));
      running[SpawnWithLog(argv, log_of(index), {"RELUME_THREADS=" + std::to_string(share)})] = index;
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
}

}  // namespace relume::batch
