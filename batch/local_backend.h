// The local backend: the batch's tasks on this machine, `workers` worker processes at a time,
// each with its output in its task's log. A worker is a process, not a thread: a task that
// crashes or is killed takes no other task with it, and each holds its own folder lock.
//
// How a worker starts (LocalStart, batch_options.h):
//  - kFork: a fork of this process calls RunBatchTask (task.h) and ends. The program and its
//    shared libraries are already loaded: starting relume costs 0.2-0.3 s (about 170 libraries
//    through OpenCV's codecs), a sixth of a small session's task. A fork copies only the thread
//    that calls it, so workers are forked only while this process runs that one thread (the
//    `relume batch` command does); otherwise they are started as with kExec.
//  - kExec: the task command (`relume batch-task PLAN INDEX ATTEMPT`) is started for each task.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "batch/batch_options.h"

namespace relume::batch {

// True when this process runs one thread (/proc/self/task), so that a fork of it is whole.
bool RunsOneThread();
// How RunLocalTasks would start workers now when asked for `start`: kExec for kFork in a process
// with threads.
LocalStart EffectiveLocalStart(LocalStart start);

// Runs the tasks `indices` and returns when all have ended; returns how the workers were started
// (kExec when kFork was asked for in a process with threads). `log_of(index)` names each task's
// log; `on_end(index, how)` is called as each ends ("exit code 0", "signal 9 (Killed)"). Each
// worker's parallel loops get its share of the CPUs: DefaultThreads() / workers, at least one.
LocalStart RunLocalTasks(const std::vector<int>& indices, int workers, LocalStart start,
                         const std::vector<std::string>& task_command, const std::filesystem::path& plan_file,
                         const std::string& attempt, const std::function<std::filesystem::path(int)>& log_of,
                         const std::function<void(int index, const std::string& how)>& on_end);

}  // namespace relume::batch
