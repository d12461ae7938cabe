#include "sim/devices/sim_backend.h"

#include <gtest/gtest.h>

#include <fstream>

#include "drivers/device_error.h"
#include "sim/devices/test_rig.h"

namespace relume::sim {
namespace {

using drivers::DeviceErrorKind;
using drivers::DeviceKind;
using testing::LookingAtWall;
using testing::TestRig;

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(SimBackendTest, DevicesAreEnumeratedAndOpenedThroughTheRegistry) {
  TestRig rig;
  SimDeviceSpec still;
  still.id = "cam0";
  still.model = "Sim DSLR";
  still.camera = LookingAtWall(16, 12);
  SimDeviceSpec rgbd;
  rgbd.id = "kinect0";
  rgbd.kind = DeviceKind::kRgbdSensor;
  rgbd.camera = LookingAtWall(16, 12);
  drivers::DeviceRegistry registry;
  registry.Add(std::make_shared<SimBackend>(std::vector<SimDeviceSpec>{still, rgbd}, rig.truth, rig.clock));
  const std::vector<drivers::DeviceInfo> found = registry.Enumerate();
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].FullId(), "sim:cam0");
  EXPECT_EQ(found[0].model, "Sim DSLR");
  EXPECT_EQ(found[0].details.at("exposure_control"), "shutter_list");
  EXPECT_EQ(found[1].kind, DeviceKind::kRgbdSensor);
  auto camera = registry.OpenStillCamera(registry.Find("cam0"));
  EXPECT_EQ(camera->Capture().device_id, "sim:cam0");
  try {
    registry.OpenStillCamera(registry.Find("cam0"));
    FAIL() << "a second handle should be denied";
  } catch (const drivers::DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kAccessDenied);
  }
  EXPECT_THROW(registry.OpenRgbdSensor(registry.Find("cam0")), InvalidArgumentError);
  EXPECT_THROW(registry.OpenStillCamera(registry.Find("kinect0")), InvalidArgumentError);
  auto sensor = registry.OpenRgbdSensor(registry.Find("sim:kinect0"));
  EXPECT_EQ(sensor->info().FullId(), "sim:kinect0");
}

TEST(SimBackendTest, DuplicateOrEmptyIdsAreRejected) {
  TestRig rig;
  SimDeviceSpec spec;
  spec.id = "cam0";
  spec.camera = LookingAtWall(8, 6);
  EXPECT_THROW(SimBackend({spec, spec}, rig.truth, rig.clock), InvalidArgumentError);
  spec.id = "";
  EXPECT_THROW(SimBackend({spec}, rig.truth, rig.clock), InvalidArgumentError);
}

TEST(SimBackendTest, ExampleRigLoads) {
  const std::vector<SimDeviceSpec> specs = LoadSimDeviceSpecs("sim/devices/example_devices.yaml");
  ASSERT_EQ(specs.size(), 4u);
  EXPECT_EQ(specs[0].still.control, drivers::ExposureControl::kShutterList);
  EXPECT_EQ(specs[0].still.model.raw_layout, ColorLayout::kBayerRggb);
  EXPECT_EQ(specs[0].still.model.response.shape, ResponseCurve::Shape::kFilmic);
  EXPECT_EQ(specs[0].still.model.vignetting.model, Vignetting::Model::kCos4);
  EXPECT_EQ(specs[0].still.sensor_temperature_c, 31.5);
  EXPECT_EQ(specs[0].still.device_clock.drift_ppm, 20.0);
  EXPECT_EQ(specs[0].faults.busy_frames.count(4), 1u);
  // look_at along +x from (0, 0, 1.5): the optical axis is world +x.
  const Eigen::Vector3d axis = specs[0].camera.world_from_camera.rotation() * Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(axis.isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_EQ(specs[1].still.control, drivers::ExposureControl::kContinuous);
  EXPECT_EQ(specs[1].still.model.response.table.size(), 6u);
  EXPECT_EQ(specs[1].camera.intrinsics.fx, 400.0);
  EXPECT_EQ(specs[1].camera.intrinsics.cx, 160.0);
  // rotation_wxyz (0.5, -0.5, 0.5, -0.5): camera z -> world +x, camera x -> world -y.
  const Eigen::Matrix3d r = specs[1].camera.world_from_camera.rotation();
  EXPECT_TRUE((r * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_TRUE((r * Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_EQ(specs[2].still.control, drivers::ExposureControl::kEvOnly);
  EXPECT_EQ(specs[2].still.metering.statistic, MeteringOptions::Statistic::kMean);
  EXPECT_EQ(specs[3].kind, DeviceKind::kRgbdSensor);
  EXPECT_EQ(specs[3].rgbd.depth.max_range_m, 4.0);
  EXPECT_NEAR(specs[3].rgbd.color_from_depth.translation().x(), -0.025, 1e-12);
  EXPECT_EQ(specs[3].rgbd.registration, Registration::kNearest);  // the hardware's way by default
  EXPECT_EQ(specs[3].faults.disconnect_at_frame, 900u);
  TestRig rig;
  SimBackend backend(specs, rig.truth, rig.clock);
  EXPECT_EQ(backend.Enumerate().size(), 4u);
}

TEST(SimBackendTest, SingleDeviceFileLoads) {
  const std::string path = WriteTemp("one_device.yaml",
                                     "id: solo\ncamera: {width: 8, height: 6, horizontal_fov_deg: 40, "
                                     "position_m: [0, 0, 0], look_at_m: [1, 0, 0]}\n");
  const std::vector<SimDeviceSpec> specs = LoadSimDeviceSpecs(path);
  ASSERT_EQ(specs.size(), 1u);
  EXPECT_EQ(specs[0].id, "solo");
  EXPECT_EQ(specs[0].kind, DeviceKind::kStillCamera);
}

// `registration: none`: a sensor without hardware registration offers only unregistered streams.
TEST(SimBackendTest, ASensorWithoutRegistrationOffersOnlyUnregisteredStreams) {
  const std::string path = WriteTemp("unregistered.yaml",
                                     "id: k2\nkind: rgbd_sensor\ncamera: {width: 320, height: 240, horizontal_fov_deg: "
                                     "58, position_m: [0, 0, 0], look_at_m: [1, 0, 0]}\nrgbd: {registration: none}\n");
  const std::vector<SimDeviceSpec> specs = LoadSimDeviceSpecs(path);
  ASSERT_EQ(specs.size(), 1u);
  ASSERT_FALSE(specs[0].rgbd.configs.empty());
  for (const drivers::RgbdStreamConfig& c : specs[0].rgbd.configs) EXPECT_FALSE(c.register_depth_to_color);
  EXPECT_EQ(specs[0].rgbd.configs.size(), SimRgbdOptions().configs.size() / 2);
}

TEST(SimBackendTest, ConfigErrorsNameTheFileLineAndKey) {
  struct Case {
    std::string yaml;
    std::string key;
    int line;
  };
  const std::string camera =
      "    camera: {width: 8, height: 6, horizontal_fov_deg: 40, position_m: [0, 0, 0], look_at_m: [1, 0, 0]}\n";
  const std::vector<Case> cases = {
      {"devices:\n  - id: a\n    exposure_control: manual\n" + camera, "exposure_control", 3},
      {"devices:\n  - id: a\n" + camera + "    sensor: {raw_bits: 13}\n", "sensor", 4},
      {"devices:\n  - id: a\n" + camera + "    sensor:\n      respnse: {shape: gamma}\n", "respnse", 5},
      {"devices:\n  - id: a\n    camera: {width: 8, height: 6, horizontal_fov_deg: 40, position_m: [0, 0]}\n",
       "position_m", 3},
      {"devices:\n  - id: a\n" + camera + "    faults: {busy_frames: oops}\n", "busy_frames", 4},
      {"devices:\n  - id: a\n    kind: rgbd_sensor\n" + camera + "    rgbd: {registration: bilinear}\n", "registration",
       5},
      {"nothing: here\n", "devices", 1},
  };
  for (const Case& c : cases) {
    const std::string path = WriteTemp("bad_devices.yaml", c.yaml);
    try {
      LoadSimDeviceSpecs(path);
      ADD_FAILURE() << "accepted:\n" << c.yaml;
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), c.key) << e.what();
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_EQ(e.file(), path);
    }
  }
}

}  // namespace
}  // namespace relume::sim
