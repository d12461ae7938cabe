// The local backend: the batch's tasks on this machine, `workers` worker processes at a time,
// each the task command (`relume batch-task PLAN INDEX ATTEMPT`) with its output in its log. A
// worker is a process, not a thread: a task that crashes or is killed takes no other task with
// it, and each holds its own folder lock.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace relume::batch {

// Runs the tasks `indices` and returns when all have ended. `log_of(index)` names each task's log;
// `on_end(index, how)` is called as each ends ("exit code 0", "signal 9 (Killed)").
void RunLocalTasks(const std::vector<int>& indices, int workers, const std::vector<std::string>& task_command,
                   const std::filesystem::path& plan_file, const std::string& attempt,
                   const std::function<std::filesystem::path(int)>& log_of,
                   const std::function<void(int index, const std::string& how)>& on_end);

}  // namespace relume::batch
