#include <gtest/gtest.h>

#include "drivers/backend.h"
#include "drivers/device_error.h"
#include "drivers/testing_camera.h"

namespace relume::drivers {
namespace {

// A backend over scripted cameras, for the registry's bookkeeping only.
class ScriptedBackend : public Backend {
 public:
  ScriptedBackend(std::string name, std::vector<std::string> ids, bool broken = false)
      : name_(std::move(name)), ids_(std::move(ids)), broken_(broken) {}
  std::string name() const override { return name_; }
  std::vector<DeviceInfo> Enumerate() override {
    if (broken_) throw Error("library failed to initialise");
    std::vector<DeviceInfo> out;
    for (const auto& id : ids_) out.push_back({name_, id, DeviceKind::kStillCamera, "model", "", "", {}});
    return out;
  }
  std::unique_ptr<StillCamera> OpenStillCamera(const DeviceInfo& info) override {
    return std::make_unique<testing::ScriptedCamera>(info.id);
  }
  std::unique_ptr<RgbdSensor> OpenRgbdSensor(const DeviceInfo& info) override {
    throw InvalidArgumentError(info.FullId() + " is not an RGB-D sensor");
  }

 private:
  std::string name_;
  std::vector<std::string> ids_;
  bool broken_;
};

TEST(RegistryTest, FindsByFullOrUniqueBareId) {
  DeviceRegistry registry;
  registry.Add(std::make_shared<ScriptedBackend>("a", std::vector<std::string>{"cam0", "cam1"}));
  registry.Add(std::make_shared<ScriptedBackend>("b", std::vector<std::string>{"cam1"}));
  EXPECT_EQ(registry.Enumerate().size(), 3u);
  EXPECT_EQ(registry.Find("cam0").backend, "a");
  EXPECT_EQ(registry.Find("b:cam1").backend, "b");
  try {
    registry.Find("cam1");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("ambiguous"), std::string::npos);
  }
  try {
    registry.Find("cam9");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kNotFound);
    EXPECT_NE(std::string(e.what()).find("a:cam0, a:cam1, b:cam1"), std::string::npos) << e.what();
  }
  const auto camera = registry.OpenStillCamera(registry.Find("a:cam1"));
  EXPECT_EQ(camera->info().id, "cam1");
}

TEST(RegistryTest, ABrokenBackendDoesNotHideTheOthers) {
  DeviceRegistry registry;
  registry.Add(std::make_shared<ScriptedBackend>("broken", std::vector<std::string>{}, true));
  registry.Add(std::make_shared<ScriptedBackend>("ok", std::vector<std::string>{"x"}));
  std::vector<std::string> problems;
  EXPECT_EQ(registry.Enumerate(&problems).size(), 1u);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("broken: library failed"), std::string::npos);
}

}  // namespace
}  // namespace relume::drivers
