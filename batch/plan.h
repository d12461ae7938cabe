// A batch's plan: which session each task processes, into which folder, with which pipeline
// options. Written once into <out>/plans/ (named by the hash of its content, never changed
// afterwards) before any task starts: a task reads its session from the plan by index, so a new
// plan written into the same batch folder cannot change what a running task does.
//
// Output folders never collide: each session's folder is <out>/sessions/<name>-<hash>, where
// <name> is the session folder's own name (letters, digits, '.', '-', '_' kept) and <hash> the
// first 12 hex digits of the SHA-256 of its absolute canonical path, so two sessions named alike
// in different places get different folders, and the same session always gets the same one (its
// stage cache is reused by every later batch into the same <out>).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"

namespace relume::batch {

struct BatchTask {
  int index = 0;
  std::filesystem::path session;  // absolute, canonical
  std::string folder;             // relative to the batch folder: "sessions/<name>-<hash>"
};

struct BatchPlan {
  pipeline::PipelineRequest request;  // the options of every task (session_dir, out_dir empty)
  std::vector<BatchTask> tasks;
};

// The session folders named by `patterns` (folders, or globs expanded with glob(3): `*`, `?`,
// `[...]`) and by `list_file` (one folder or glob a line; blank lines and `#` comments skipped;
// relative paths are relative to the list file's folder), in the order given, each once
// (duplicates by canonical path dropped). InvalidArgumentError naming the pattern or line that
// matches nothing, or the folder that is not a relume session (no session.sqlite).
std::vector<std::filesystem::path> ExpandSessions(const std::vector<std::string>& patterns,
                                                  const std::optional<std::filesystem::path>& list_file);

// "sessions/<name>-<hash12>" for a canonical session path (see the top of this file).
std::string SessionFolderName(const std::filesystem::path& canonical_session);

BatchPlan MakePlan(const std::vector<std::filesystem::path>& sessions, const pipeline::PipelineRequest& request);

nlohmann::json PlanToJson(const BatchPlan& plan);
// InvalidArgumentError naming `source` when the JSON is not a plan.
BatchPlan PlanFromJson(const nlohmann::json& j, const std::string& source);

// Writes the plan into <out>/plans/plan-<hash12>.json (durably; an identical plan is the same
// file) and returns its path.
std::filesystem::path WritePlan(const BatchPlan& plan, const std::filesystem::path& out_dir);
BatchPlan ReadPlan(const std::filesystem::path& file);

// Reads a JSON file relume wrote (IoError naming it when missing or unreadable, InvalidArgument
// when it is not JSON), and writes one durably (temporary name, fsync, rename).
nlohmann::json ReadJson(const std::filesystem::path& file);
void WriteJsonDurably(const std::filesystem::path& file, const nlohmann::json& j);

}  // namespace relume::batch
