// Content-keyed stage outputs for `relume process`: a stage whose inputs (content hashes) and
// settings have not changed is not recomputed (DESIGN.md, "Skip what a scene does not need").
//
// Each stage run owns one folder, <root>/<stage>-<key>/, where <key> is a hash of everything
// the stage's result depends on (a StageKey). The folder is produced under a temporary name
// and renamed into place only after the stage finished and its manifest (stage.json) is
// written, so a run stopped by Ctrl-C or a crash leaves no half-written stage behind: the
// next run removes the temporary folder and computes the stage again.
//
// Every key also holds the code that computes it (CodeVersion: relume's, OpenCV's, Embree's and
// Eigen's versions and the SHA-256 of the sources that compute stage results, made by the
// build: pipeline/CMakeLists.txt), so results of other code are recomputed
// rather than trusted; the "stage" field of each key (e.g. "radiance-v1") names the stage's
// algorithm for people reading stage.json.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace relume::pipeline {

// What a stage's output depends on, as named fields. Order matters (fields are hashed in the
// order they are added). Hex() is the SHA-256 of the fields; Describe() lists them for logs.
class StageKey {
 public:
  StageKey& Add(std::string_view name, std::string_view value);
  StageKey& Add(std::string_view name, const char* value) { return Add(name, std::string_view(value)); }
  StageKey& Add(std::string_view name, const std::string& value) { return Add(name, std::string_view(value)); }
  StageKey& Add(std::string_view name, double value);  // exact (hex float), not rounded
  StageKey& Add(std::string_view name, std::int64_t value);
  StageKey& Add(std::string_view name, int value) { return Add(name, static_cast<std::int64_t>(value)); }
  StageKey& Add(std::string_view name, bool value) { return Add(name, value ? "true" : "false"); }
  // The SHA-256 of a file's content (not its name or time).
  StageKey& AddFileContent(std::string_view name, const std::filesystem::path& path);
  // Another stage's key: this stage depends on everything that one depends on.
  StageKey& AddKey(std::string_view name, const StageKey& other) { return Add(name, other.Hex()); }

  std::string Hex() const;  // 64 hex digits
  std::string Describe() const;

 private:
  std::vector<std::pair<std::string, std::string>> fields_;
};

// relume's, OpenCV's, Embree's and Eigen's versions and the first 16 hex digits of the SHA-256 of
// the sources that compute stage results (the same for the CLI, the tests and any other program
// built from the same sources).
const std::string& CodeVersion();

// Where a run's stage outputs live and how long (PipelineRequest::store). A stage is a folder of
// files either way: stages write images and records with file writers (OpenCV, OpenEXR, JSON),
// and the outputs a summary lists are files a user opens.
class StageStore {
 public:
  struct Result {
    std::filesystem::path dir;  // the stage's completed folder
    bool reused = false;        // true: found complete, `produce` not called
    std::string key;            // StageKey::Hex() with the code version
  };
  virtual ~StageStore() = default;

  // Runs `produce(folder)` unless the store holds a completed stage for (stage, key). `produce`
  // writes its outputs into the folder it is given (one that becomes `dir`).
  virtual Result Run(std::string_view stage, const StageKey& key,
                     const std::function<void(const std::filesystem::path&)>& produce) = 0;
  virtual bool IsComplete(std::string_view stage, const StageKey& key) const = 0;
  // Where the stages are and how long they are kept, for the summary.
  virtual std::string Describe() const = 0;
};

// The directory store: stage folders under `root`, kept and reused across runs (`relume process`
// uses OUT/stages).
class StageCache final : public StageStore {
 public:
  // `root` is created when missing. With `reuse` false every stage is recomputed (and its
  // folder replaced), as `relume process --force` asks. `code_version` is added to every key.
  explicit StageCache(std::filesystem::path root, bool reuse = true, std::string code_version = CodeVersion());

  // A completed folder from an earlier run is reused.
  Result Run(std::string_view stage, const StageKey& key,
             const std::function<void(const std::filesystem::path&)>& produce) override;

  // The folder a completed stage would have, without running anything.
  std::filesystem::path DirFor(std::string_view stage, const StageKey& key) const;
  bool IsComplete(std::string_view stage, const StageKey& key) const override;
  std::string Describe() const override;

  const std::filesystem::path& root() const { return root_; }

 private:
  StageKey WithCode(const StageKey& key) const;

  std::filesystem::path root_;
  bool reuse_;
  std::string code_version_;
};

// The in-memory store: stage folders in a private temporary folder (in /dev/shm, RAM-backed,
// when it exists and is writable; else the system's temporary folder), deleted with the store.
// A run leaves no cache behind; stages repeat only within the store's life (two runs through one
// store reuse each other's). For a caller that wants a pipeline's typed summary and outputs and
// no cache (a test, a Python session, a one-off job): the summary's outputs point into the store
// and live as long as it does.
class TemporaryStageStore final : public StageStore {
 public:
  explicit TemporaryStageStore(std::string code_version = CodeVersion());
  ~TemporaryStageStore() override;
  TemporaryStageStore(const TemporaryStageStore&) = delete;
  TemporaryStageStore& operator=(const TemporaryStageStore&) = delete;

  Result Run(std::string_view stage, const StageKey& key,
             const std::function<void(const std::filesystem::path&)>& produce) override;
  bool IsComplete(std::string_view stage, const StageKey& key) const override;
  std::string Describe() const override;
  const std::filesystem::path& root() const { return root_; }

 private:
  std::filesystem::path root_;
  std::unique_ptr<StageCache> folders_;
};

}  // namespace relume::pipeline
