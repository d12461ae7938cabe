#include "pipeline/stage_cache.h"

#include <embree3/rtcore_config.h>
#include <unistd.h>

#include <Eigen/Core>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core/version.hpp>
#include <span>
#include <system_error>

#include "capture/durable_file.h"
#include "core/error.h"
#include "pipeline/code_version.h"

namespace relume::pipeline {
namespace fs = std::filesystem;

namespace {
constexpr const char* kManifest = "stage.json";
constexpr const char* kPartialSuffix = ".partial";
}  // namespace

const std::string& CodeVersion() {
  static const std::string version = std::string("relume ") + RELUME_VERSION + ", opencv " + CV_VERSION + ", embree " +
                                     RTC_VERSION_STRING + ", eigen " + std::to_string(EIGEN_WORLD_VERSION) + "." +
                                     std::to_string(EIGEN_MAJOR_VERSION) + "." + std::to_string(EIGEN_MINOR_VERSION) +
                                     ", code " + std::string(RELUME_CODE_HASH).substr(0, 16);
  return version;
}

StageKey& StageKey::Add(std::string_view name, std::string_view value) {
  fields_.emplace_back(std::string(name), std::string(value));
  return *this;
}

StageKey& StageKey::Add(std::string_view name, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), "%a", value);
  return Add(name, std::string_view(text));
}

StageKey& StageKey::Add(std::string_view name, std::int64_t value) {
  return Add(name, std::to_string(value));
}

StageKey& StageKey::AddFileContent(std::string_view name, const fs::path& path) {
  return Add(name, capture::Sha256HexOfFile(path));
}

std::string StageKey::Hex() const {
  std::string text;
  for (const auto& [name, value] : fields_) {
    // Length-prefixed so that ("ab","c") and ("a","bc") differ.
    text += std::to_string(name.size()) + ":" + name + "=" + std::to_string(value.size()) + ":" + value + ";";
  }
  return capture::Sha256Hex(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

std::string StageKey::Describe() const {
  std::string text;
  for (const auto& [name, value] : fields_) {
    if (!text.empty()) text += ", ";
    text += name + "=" + (value.size() > 16 ? value.substr(0, 12) + "..." : value);
  }
  return text;
}

StageCache::StageCache(fs::path root, bool reuse, std::string code_version)
    : root_(std::move(root)), reuse_(reuse), code_version_(std::move(code_version)) {
  std::error_code ec;
  fs::create_directories(root_, ec);
  if (ec) throw IoError(root_.string(), "cannot create the stage folder: " + ec.message());
}

StageKey StageCache::WithCode(const StageKey& key) const {
  StageKey full = key;
  if (!code_version_.empty()) full.Add("code", code_version_);
  return full;
}

fs::path StageCache::DirFor(std::string_view stage, const StageKey& key) const {
  return root_ / (std::string(stage) + "-" + WithCode(key).Hex().substr(0, 16));
}

bool StageCache::IsComplete(std::string_view stage, const StageKey& key) const {
  return fs::exists(DirFor(stage, key) / kManifest);
}

StageStore::Result StageCache::Run(std::string_view stage, const StageKey& key,
                                   const std::function<void(const fs::path&)>& produce) {
  Result result;
  result.dir = DirFor(stage, key);
  result.key = WithCode(key).Hex();
  if (reuse_ && IsComplete(stage, key)) {
    result.reused = true;
    return result;
  }
  const fs::path partial = result.dir.string() + kPartialSuffix;
  std::error_code ec;
  fs::remove_all(partial, ec);  // left by a run that was stopped mid-stage
  if (ec) throw IoError(partial.string(), "cannot remove the unfinished stage folder: " + ec.message());
  fs::create_directories(partial, ec);
  if (ec) throw IoError(partial.string(), "cannot create the stage folder: " + ec.message());

  produce(partial);

  nlohmann::json manifest;
  manifest["stage"] = std::string(stage);
  manifest["key"] = result.key;
  manifest["depends_on"] = WithCode(key).Describe();
  manifest["code"] = code_version_;
  const std::string text = manifest.dump(2) + "\n";
  capture::WriteFileDurably(partial / kManifest,
                            std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  fs::remove_all(result.dir, ec);  // a forced recomputation replaces the old folder
  fs::rename(partial, result.dir, ec);
  if (ec) throw IoError(result.dir.string(), "cannot move the stage folder into place: " + ec.message());
  capture::SyncDirectory(root_);
  return result;
}

std::string StageCache::Describe() const {
  return "stage folders in " + root_.string() + ", kept and reused by later runs" +
         (reuse_ ? "" : " (this run recomputes every stage)");
}

namespace {

// A new, private folder for a TemporaryStageStore: in /dev/shm when writable, else the system's
// temporary folder.
fs::path MakeTemporaryRoot() {
  std::vector<fs::path> bases;
  std::error_code ec;
  if (fs::is_directory("/dev/shm", ec) && ::access("/dev/shm", W_OK) == 0) bases.emplace_back("/dev/shm");
  bases.push_back(fs::temp_directory_path(ec));
  for (const fs::path& base : bases) {
    std::string pattern = (base / "relume-stages-XXXXXX").string();
    if (::mkdtemp(pattern.data()) != nullptr) return pattern;
  }
  throw IoError(bases.back().string(), "cannot create a temporary stage folder: " + std::string(std::strerror(errno)) +
                                           " (set TMPDIR to a writable folder)");
}

}  // namespace

TemporaryStageStore::TemporaryStageStore(std::string code_version)
    : root_(MakeTemporaryRoot()), folders_(std::make_unique<StageCache>(root_, true, std::move(code_version))) {}

TemporaryStageStore::~TemporaryStageStore() {
  std::error_code ec;
  fs::remove_all(root_, ec);  // best effort: nothing in it is the user's
}

StageStore::Result TemporaryStageStore::Run(std::string_view stage, const StageKey& key,
                                            const std::function<void(const fs::path&)>& produce) {
  return folders_->Run(stage, key, produce);
}

bool TemporaryStageStore::IsComplete(std::string_view stage, const StageKey& key) const {
  return folders_->IsComplete(stage, key);
}

std::string TemporaryStageStore::Describe() const {
  const bool memory = root_.string().rfind("/dev/shm/", 0) == 0;
  return std::string("stage folders ") + (memory ? "in memory (" : "in a temporary folder (") + root_.string() +
         "), deleted with the store";
}

}  // namespace relume::pipeline
