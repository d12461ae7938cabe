// Reading relume's YAML files (sites, scenes, rigs) with errors that name the file, the line,
// the key and what was expected (relume::ConfigError).
#pragma once

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <string>

#include "core/site.h"

namespace relume {

// A parsed YAML file that remembers its path for error messages.
class YamlFile {
 public:
  // Throws IoError when the file cannot be read (missing, a directory), ConfigError when it is
  // not valid YAML or its top level is not a mapping.
  explicit YamlFile(std::string path);

  const std::string& path() const { return path_; }
  const YAML::Node& root() const { return root_; }

  // A required finite number; ConfigError names the key when missing or not a number.
  double RequireDouble(const YAML::Node& map, const std::string& key) const;
  // A required whole number within [min, max], checked as a double before it is narrowed to an
  // int (so 1e12 reads as out of range, not as an overflowed negative count).
  int RequireInt(const YAML::Node& map, const std::string& key, int min, int max) const;
  std::string RequireString(const YAML::Node& map, const std::string& key) const;
  // Rejects keys not in `allowed` (catches typos such as "lattitude").
  void RejectUnknownKeys(const YAML::Node& map, std::initializer_list<const char*> allowed) const;
  [[noreturn]] void Fail(const YAML::Node& at, const std::string& key, const std::string& what) const;

 private:
  std::string path_;
  YAML::Node root_;
};

// A site file: name, latitude_deg, longitude_deg, height_m (see config/sites/).
struct SiteConfig {
  std::string name;
  Site site;
};
SiteConfig LoadSiteConfig(const std::string& path);

}  // namespace relume
