#include "core/yaml_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"

namespace relume {
namespace {

class YamlConfigTest : public ::testing::Test {
 protected:
  std::string Write(const std::string& name, const std::string& text) {
    const auto path = std::filesystem::path(::testing::TempDir()) / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::string ErrorOf(const std::string& path) {
    try {
      LoadSiteConfig(path);
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  }
};

TEST_F(YamlConfigTest, LoadsTheShippedSite) {
  const SiteConfig config = LoadSiteConfig("config/sites/athens-acropolis.yaml");
  EXPECT_EQ(config.name, "athens-acropolis");
  EXPECT_NEAR(config.site.latitude_deg(), 37.97153, 1e-12);
  EXPECT_NEAR(config.site.height_m, 190.0, 1e-12);
}

TEST_F(YamlConfigTest, ErrorsNameFileLineAndKey) {
  const std::string bad_number = Write("a.yaml", "name: x\nlatitude_deg: north\nlongitude_deg: 3\n");
  EXPECT_EQ(ErrorOf(bad_number), bad_number + ":2: latitude_deg: 'north' is not a finite number");
  const std::string typo = Write("b.yaml", "name: x\nlattitude_deg: 1\nlongitude_deg: 3\n");
  EXPECT_NE(ErrorOf(typo).find(":2: lattitude_deg: unknown key"), std::string::npos) << ErrorOf(typo);
  const std::string missing = Write("c.yaml", "name: x\nlongitude_deg: 3\n");
  EXPECT_NE(ErrorOf(missing).find("latitude_deg: missing"), std::string::npos) << ErrorOf(missing);
  const std::string out_of_range = Write("d.yaml", "name: x\nlatitude_deg: 91\nlongitude_deg: 3\n");
  EXPECT_NE(ErrorOf(out_of_range).find("latitude 91"), std::string::npos) << ErrorOf(out_of_range);
  const std::string broken = Write("e.yaml", "name: [x\n");
  EXPECT_NE(ErrorOf(broken).find("not valid YAML"), std::string::npos) << ErrorOf(broken);
  EXPECT_NE(ErrorOf("/nonexistent/site.yaml").find("cannot open"), std::string::npos);
}

}  // namespace
}  // namespace relume
