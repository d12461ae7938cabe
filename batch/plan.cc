#include "batch/plan.h"

#include <glob.h>

#include <fstream>
#include <set>
#include <span>
#include <sstream>

#include "capture/durable_file.h"
#include "capture/session.h"
#include "core/error.h"

namespace relume::batch {
namespace fs = std::filesystem;

namespace {

bool HasGlobCharacters(const std::string& text) {
  return text.find_first_of("*?[") != std::string::npos;
}

// The paths a glob matches, sorted (glob(3) sorts); empty when none.
std::vector<fs::path> Glob(const std::string& pattern) {
  glob_t found{};
  const int rc = ::glob(pattern.c_str(), 0, nullptr, &found);
  std::vector<fs::path> paths;
  if (rc == 0) {
    for (std::size_t i = 0; i < found.gl_pathc; ++i) paths.emplace_back(found.gl_pathv[i]);
  }
  ::globfree(&found);
  if (rc != 0 && rc != GLOB_NOMATCH) {
    throw InvalidArgumentError("session pattern '" + pattern + "': cannot be read (" +
                               (rc == GLOB_NOSPACE ? "out of memory" : "a folder it names cannot be listed") + ")");
  }
  return paths;
}

void CheckIsSession(const fs::path& folder, const std::string& from) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw InvalidArgumentError(from + ": " + folder.string() +
                               (fs::exists(folder, ec) ? " is not a folder" : " does not exist") +
                               "; give session folders made by `relume capture`");
  }
  if (!fs::is_regular_file(folder / capture::kSessionDatabaseName, ec)) {
    throw InvalidArgumentError(from + ": " + folder.string() + " is not a relume session (no " +
                               capture::kSessionDatabaseName + "); remove it from the list or narrow the glob");
  }
}

void AddPattern(const std::string& pattern, const fs::path& base, const std::string& from, std::vector<fs::path>& out,
                std::set<fs::path>& seen) {
  const fs::path path = fs::path(pattern).is_absolute() ? fs::path(pattern) : base / pattern;
  std::vector<fs::path> matches;
  if (HasGlobCharacters(pattern)) {
    matches = Glob(path.string());
    if (matches.empty()) {
      throw InvalidArgumentError(from + ": the pattern '" + pattern + "' matches nothing" +
                                 (base.empty() ? std::string() : " (relative to " + base.string() + ")") +
                                 "; check the path, and quote the pattern so that relume expands it");
    }
  } else {
    matches.push_back(path);
  }
  for (const fs::path& m : matches) {
    CheckIsSession(m, from);
    const fs::path canonical = fs::canonical(m);
    if (seen.insert(canonical).second) out.push_back(canonical);
  }
}

std::string Trim(const std::string& text) {
  const std::size_t begin = text.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  const std::size_t end = text.find_last_not_of(" \t\r");
  return text.substr(begin, end - begin + 1);
}

nlohmann::json RequestToJson(const pipeline::PipelineRequest& r) {
  nlohmann::json j;
  j["pipeline"] = r.pipeline;
  j["source"] = r.source ? nlohmann::json(*r.source) : nlohmann::json();
  j["target"] = r.target ? nlohmann::json(*r.target) : nlohmann::json();
  j["mesh"] = r.mesh ? nlohmann::json(fs::absolute(*r.mesh).string()) : nlohmann::json();
  // A file (SH .json, environment map) by its absolute path: tasks may run in another folder. A
  // frame selector stays as given.
  std::error_code ec;
  j["target_light"] = !r.target_light ? nlohmann::json()
                      : fs::is_regular_file(*r.target_light, ec)
                          ? nlohmann::json(fs::absolute(*r.target_light).string())
                          : nlohmann::json(*r.target_light);
  j["settings"] = r.settings;
  j["reuse"] = r.reuse;
  return j;
}

pipeline::PipelineRequest RequestFromJson(const nlohmann::json& j) {
  pipeline::PipelineRequest r;
  r.pipeline = j.at("pipeline").get<std::string>();
  if (!j.at("source").is_null()) r.source = j["source"].get<std::string>();
  if (!j.at("target").is_null()) r.target = j["target"].get<std::string>();
  if (!j.at("mesh").is_null()) r.mesh = j["mesh"].get<std::string>();
  if (!j.at("target_light").is_null()) r.target_light = j["target_light"].get<std::string>();
  r.settings = j.at("settings").get<std::map<std::string, std::string>>();
  r.reuse = j.at("reuse").get<bool>();
  return r;
}

}  // namespace

std::vector<fs::path> ExpandSessions(const std::vector<std::string>& patterns,
                                     const std::optional<fs::path>& list_file) {
  std::vector<fs::path> sessions;
  std::set<fs::path> seen;
  for (const std::string& pattern : patterns)
    AddPattern(pattern, fs::path(), "session '" + pattern + "'", sessions, seen);
  if (list_file) {
    std::ifstream in(*list_file);
    if (!in) throw IoError(list_file->string(), "cannot read the session list (give a text file, a folder a line)");
    const fs::path base = fs::absolute(*list_file).parent_path();
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      const std::string text = Trim(line);
      if (text.empty() || text.front() == '#') continue;
      AddPattern(text, base, list_file->string() + ":" + std::to_string(number), sessions, seen);
    }
  }
  return sessions;
}

std::string SessionFolderName(const fs::path& canonical_session) {
  std::string name;
  for (const char c : canonical_session.filename().string()) {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '.' || c == '-' || c == '_';
    name += keep ? c : '_';
  }
  if (name.empty() || name.front() == '.') name = "session" + name;
  const std::string path = canonical_session.string();
  const std::string hash =
      capture::Sha256Hex(std::span(reinterpret_cast<const std::uint8_t*>(path.data()), path.size())).substr(0, 12);
  return "sessions/" + name + "-" + hash;
}

BatchPlan MakePlan(const std::vector<fs::path>& sessions, const pipeline::PipelineRequest& request) {
  BatchPlan plan;
  plan.request = request;
  for (const fs::path& session : sessions) {
    const fs::path canonical = fs::weakly_canonical(fs::absolute(session));
    plan.tasks.push_back({static_cast<int>(plan.tasks.size()), canonical, SessionFolderName(canonical)});
  }
  return plan;
}

nlohmann::json PlanToJson(const BatchPlan& plan) {
  nlohmann::json j;
  j["format"] = "relume-batch-plan-1";
  j["request"] = RequestToJson(plan.request);
  j["tasks"] = nlohmann::json::array();
  for (const BatchTask& t : plan.tasks) {
    j["tasks"].push_back({{"index", t.index}, {"session", t.session.string()}, {"folder", t.folder}});
  }
  return j;
}

BatchPlan PlanFromJson(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object() || j.value("format", "") != "relume-batch-plan-1") {
    throw InvalidArgumentError(source + ": not a relume batch plan (format relume-batch-plan-1)");
  }
  try {
    BatchPlan plan;
    plan.request = RequestFromJson(j.at("request"));
    for (const nlohmann::json& t : j.at("tasks")) {
      plan.tasks.push_back(
          {t.at("index").get<int>(), t.at("session").get<std::string>(), t.at("folder").get<std::string>()});
    }
    return plan;
  } catch (const nlohmann::json::exception& e) {
    throw InvalidArgumentError(source + ": a malformed batch plan (" + e.what() + ")");
  }
}

fs::path WritePlan(const BatchPlan& plan, const fs::path& out_dir) {
  const nlohmann::json j = PlanToJson(plan);
  const std::string text = j.dump(2);
  const std::string hash =
      capture::Sha256Hex(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size())).substr(0, 12);
  const fs::path file = out_dir / "plans" / ("plan-" + hash + ".json");
  capture::CreateDirectoryDurably(file.parent_path());
  if (!fs::exists(file)) WriteJsonDurably(file, j);
  return file;
}

BatchPlan ReadPlan(const fs::path& file) {
  return PlanFromJson(ReadJson(file), file.string());
}

nlohmann::json ReadJson(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw IoError(file.string(), "cannot be read");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InvalidArgumentError(file.string() + ": not JSON (" + e.what() + ")");
  }
}

void WriteJsonDurably(const fs::path& file, const nlohmann::json& j) {
  const std::string text = j.dump(2) + "\n";
  capture::WriteFileDurably(file, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

}  // namespace relume::batch
