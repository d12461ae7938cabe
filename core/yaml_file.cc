#include "core/yaml_file.h"

#include <cmath>
#include <fstream>

#include "core/error.h"
#include "core/input_file.h"

namespace relume {

YamlFile::YamlFile(std::string path) : path_(std::move(path)) {
  std::ifstream stream = OpenInputFile(path_);
  try {
    root_ = YAML::Load(stream);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path_, e.mark.line + 1, "", "not valid YAML: " + e.msg);
  }
  if (!root_.IsMap()) throw ConfigError(path_, 1, "", "expected a mapping of keys to values at the top level");
}

void YamlFile::Fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
  const int line = at.IsDefined() && at.Mark().line >= 0 ? at.Mark().line + 1 : 0;
  throw ConfigError(path_, line, key, what);
}

double YamlFile::RequireDouble(const YAML::Node& map, const std::string& key) const {
  const YAML::Node value = map[key];
  if (!value.IsDefined() || value.IsNull()) Fail(map, key, "missing; expected a number");
  if (!value.IsScalar()) Fail(value, key, "expected a number");
  double number = 0.0;
  if (!YAML::convert<double>::decode(value, number) || !std::isfinite(number)) {
    Fail(value, key, "'" + value.Scalar() + "' is not a finite number");
  }
  return number;
}

int YamlFile::RequireInt(const YAML::Node& map, const std::string& key, int min, int max) const {
  const double number = RequireDouble(map, key);
  if (number != std::floor(number) || number < min || number > max) {
    Fail(map[key], key,
         "'" + map[key].Scalar() + "' is not a whole number in [" + std::to_string(min) + ", " + std::to_string(max) +
             "]");
  }
  return static_cast<int>(number);
}

std::string YamlFile::RequireString(const YAML::Node& map, const std::string& key) const {
  const YAML::Node value = map[key];
  if (!value.IsDefined() || value.IsNull()) Fail(map, key, "missing; expected text");
  if (!value.IsScalar()) Fail(value, key, "expected text");
  return value.Scalar();
}

void YamlFile::RejectUnknownKeys(const YAML::Node& map, std::initializer_list<const char*> allowed) const {
  for (const auto& entry : map) {
    const std::string key = entry.first.Scalar();
    bool known = false;
    for (const char* name : allowed) known = known || key == name;
    if (!known) {
      std::string list;
      for (const char* name : allowed) list += std::string(list.empty() ? "" : ", ") + name;
      Fail(entry.first, key, "unknown key; expected one of: " + list);
    }
  }
}

SiteConfig LoadSiteConfig(const std::string& path) {
  const YamlFile file(path);
  const YAML::Node& root = file.root();
  file.RejectUnknownKeys(root, {"name", "latitude_deg", "longitude_deg", "height_m"});
  SiteConfig config;
  config.name = file.RequireString(root, "name");
  const double latitude = file.RequireDouble(root, "latitude_deg");
  const double longitude = file.RequireDouble(root, "longitude_deg");
  const double height = root["height_m"] ? file.RequireDouble(root, "height_m") : 0.0;
  config.site = Site{DegToRad(latitude), DegToRad(longitude), height};
  std::string why;
  if (!config.site.IsValid(&why)) file.Fail(root, "site", why);
  return config;
}

}  // namespace relume
