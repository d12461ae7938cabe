#include "pipeline/fields.h"

#include <fstream>

namespace relume::pipeline {

void WriteJsonFile(const std::filesystem::path& path, const nlohmann::json& json) {
  std::ofstream out(path);
  out << json.dump(1) << "\n";
  if (!out) throw IoError(path.string(), "cannot be written (is the disk full?)");
}

nlohmann::json ReadJsonFile(const std::filesystem::path& path, const std::string& remedy) {
  std::ifstream in(path);
  if (!in) throw IoError(path.string(), "cannot be read (" + remedy + ")");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path.string(), std::string("is not valid JSON: ") + e.what() + " (" + remedy + ")");
  }
}

}  // namespace relume::pipeline
