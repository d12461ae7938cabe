// End-to-end tests of the OpenNI2 backend through the real libOpenNI2, against the simulated
// RGB-D driver (simdriver/). CTest puts the build's openni2-runtime folder (a link to
// libOpenNI2.so.0 and an OpenNI2/Drivers folder with only the simulated driver and the file
// driver) first on LD_LIBRARY_PATH. Tests named Hardware* use the installed drivers.
#include "drivers/openni2/openni2_backend.h"

// OpenNI.h's inline openni::Array::operator[] trips GCC's -Wnull-dereference (reported in the
// header once inlined, where -isystem does not silence it); the warning is about OpenNI's code.
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <OpenNI.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include "capture/rgbd_geometry.h"
#include "capture/session.h"
#include "core/time.h"
#include "drivers/device_error.h"

namespace relume::drivers::openni2 {
namespace {

constexpr const char* kSimUri = "relume-sim://rgbd/0";

// The simulated scene, written out here from its documented definition
// (docs/backends-gphoto2-openni2.md): depth z (metres) seen through pixel (u, v) of a W x H
// camera, 58 deg horizontal FOV, centred at (origin_x, 0, 0) in the colour camera's frame.
std::optional<double> SceneDepth(int u, int v, int width, int height, double origin_x) {
  const double f = (width / 2.0) / std::tan(29.0 * M_PI / 180.0);
  const Eigen::Vector3d d((u + 0.5 - width / 2.0) / f, (v + 0.5 - height / 2.0) / f, 1.0);
  const Eigen::Vector3d o(origin_x, 0.0, 0.0);
  double best = INFINITY;
  const Eigen::Vector3d oc = o - Eigen::Vector3d(0.1, 0.0, 1.5);
  const double a = d.squaredNorm(), b = 2.0 * oc.dot(d), c = oc.squaredNorm() - 0.25 * 0.25;
  if (b * b - 4 * a * c >= 0.0) {
    const double t = (-b - std::sqrt(b * b - 4 * a * c)) / (2 * a);
    if (t > 0) best = t;
  }
  const double t_plane = 2.0 / (d.z() + 0.3 * d.y());  // z = 2 - 0.3 y, o.y = o.z = 0
  if (t_plane > 0 && t_plane < best && std::abs(o.x() + t_plane * d.x()) <= 1.0) best = t_plane;
  if (!std::isfinite(best)) return std::nullopt;
  return best * d.z();
}

RgbdStreamConfig Config(int width, int height, bool registered) {
  RgbdStreamConfig config;
  config.depth_width = config.color_width = width;
  config.depth_height = config.color_height = height;
  config.fps = 30.0;
  config.register_depth_to_color = registered;
  config.sync_depth_and_color = true;
  return config;
}

// Largest |measured - analytic| over a pixel grid; counts holes that disagree.
struct DepthCheck {
  double worst_m = 0.0;
  int hole_mismatches = 0;
  int holes = 0;
  int compared = 0;
};
DepthCheck CheckDepth(const cv::Mat& depth_m, double origin_x, int x0 = 0, int y0 = 0, int full_w = 0, int full_h = 0) {
  DepthCheck check;
  if (full_w == 0) full_w = depth_m.cols;
  if (full_h == 0) full_h = depth_m.rows;
  for (int y = 0; y < depth_m.rows; y += 3) {
    for (int x = 0; x < depth_m.cols; x += 3) {
      const std::optional<double> expected = SceneDepth(x + x0, y + y0, full_w, full_h, origin_x);
      const float measured = depth_m.at<float>(y, x);
      if (!expected) {
        ++check.holes;
        if (!std::isnan(measured)) ++check.hole_mismatches;
        continue;
      }
      if (std::isnan(measured)) {
        ++check.hole_mismatches;
        continue;
      }
      check.worst_m = std::max(check.worst_m, std::abs(measured - *expected));
      ++check.compared;
    }
  }
  return check;
}

class OpenNI2BackendTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* path = std::getenv("LD_LIBRARY_PATH");
    if (path == nullptr || std::string(path).find("openni2-runtime") == std::string::npos) {
      GTEST_SKIP() << "LD_LIBRARY_PATH does not name the build's openni2-runtime folder: run through ctest";
    }
  }
};

TEST_F(OpenNI2BackendTest, EnumeratesTheSimulatedSensor) {
  OpenNI2Backend backend;
  const std::vector<DeviceInfo> devices = backend.Enumerate();
  ASSERT_EQ(devices.size(), 1u);  // the runtime folder holds only the simulated driver (+ file driver)
  EXPECT_EQ(devices[0].backend, "openni2");
  EXPECT_EQ(devices[0].id, kSimUri);
  EXPECT_EQ(devices[0].kind, DeviceKind::kRgbdSensor);
  EXPECT_EQ(devices[0].model, "Simulated RGB-D");
  EXPECT_EQ(devices[0].details.at("vendor"), "relume");
  const std::unique_ptr<RgbdSensor> sensor = backend.OpenRgbdSensor(devices[0]);
  EXPECT_EQ(sensor->info().serial, "SIMRGBD0");
  EXPECT_THROW(backend.OpenStillCamera(devices[0]), InvalidArgumentError);
}

TEST_F(OpenNI2BackendTest, ListsVideoModesAndRegistration) {
  OpenNI2Backend backend;
  const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
  EXPECT_TRUE(sensor->SupportsRegistration());
  EXPECT_FALSE(sensor->IsPlayback());
  const std::vector<RgbdStreamConfig> configs = sensor->SupportedConfigs();
  // 2 depth modes x 2 colour modes x registration on/off x sync on/off.
  EXPECT_EQ(configs.size(), 16u);
  const auto has = [&](int w, int h, bool registered) {
    return std::any_of(configs.begin(), configs.end(), [&](const RgbdStreamConfig& c) {
      return c.depth_width == w && c.depth_height == h && c.color_width == w && c.fps == 30.0 &&
             c.register_depth_to_color == registered;
    });
  };
  EXPECT_TRUE(has(640, 480, true));
  EXPECT_TRUE(has(640, 480, false));
  EXPECT_TRUE(has(320, 240, true));
}

TEST_F(OpenNI2BackendTest, UnregisteredDepthMatchesTheDepthCamerasView) {
  OpenNI2Backend backend;
  const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
  sensor->Start(Config(640, 480, false));
  EXPECT_FALSE(sensor->RegistrationEnabled());
  const RgbdFrame frame = sensor->WaitForFrame(std::chrono::seconds(5));
  EXPECT_FALSE(frame.registered_to_color);
  ASSERT_EQ(frame.depth_m.type(), CV_32FC1);
  ASSERT_EQ(frame.depth_m.cols, 640);
  ASSERT_EQ(frame.depth_m.rows, 480);
  const DepthCheck check = CheckDepth(frame.depth_m, -0.025);
  EXPECT_LE(check.worst_m, 0.0005 + 1e-6);  // millimetre rounding
  EXPECT_GT(check.holes, 100);              // beyond the plane's side edges: NaN, never 0
  EXPECT_EQ(check.hole_mismatches, 0);
  // Sphere front at the centre of the colour view is 1.25 m; intrinsics from the FOV.
  const double f = 320.0 / std::tan(29.0 * M_PI / 180.0);
  EXPECT_NEAR(frame.depth_intrinsics.fx, f, 1e-3 * f);
  EXPECT_NEAR(frame.depth_intrinsics.fy, f, 1e-3 * f);
  EXPECT_DOUBLE_EQ(frame.depth_intrinsics.cx, 320.0);
  EXPECT_TRUE(frame.color_from_depth.isApprox(Eigen::Isometry3d::Identity()));
}

TEST_F(OpenNI2BackendTest, RegisteredDepthMatchesTheColourCamerasView) {
  OpenNI2Backend backend;
  const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
  sensor->Start(Config(640, 480, true));
  EXPECT_TRUE(sensor->RegistrationEnabled());
  const RgbdFrame frame = sensor->WaitForFrame(std::chrono::seconds(5));
  EXPECT_TRUE(frame.registered_to_color);
  const DepthCheck check = CheckDepth(frame.depth_m, 0.0);
  EXPECT_LE(check.worst_m, 0.0005 + 1e-6);
  EXPECT_EQ(check.hole_mismatches, 0);
  // The registered view differs from the depth camera's own (25 mm baseline).
  EXPECT_GT(CheckDepth(frame.depth_m, -0.025).hole_mismatches + (CheckDepth(frame.depth_m, -0.025).worst_m > 0.01), 0);
  EXPECT_EQ(frame.depth_intrinsics.fx, frame.color_intrinsics.fx);
  // Colour: the sphere (reddish) at the image centre, the plane grey at the top-left.
  const cv::Vec3b centre = frame.color.pixels.at<cv::Vec3b>(240, 340);
  EXPECT_GT(centre[0], 2 * centre[1]);
  const cv::Vec3b corner = frame.color.pixels.at<cv::Vec3b>(20, 100);
  EXPECT_EQ(corner[0], corner[1]);
  EXPECT_TRUE(corner[0] == 220 || corner[0] == 40);
  EXPECT_EQ(frame.color.layout, ColorLayout::kRgb);
}

TEST_F(OpenNI2BackendTest, SmallModeAndSyncedIncreasingTimestamps) {
  OpenNI2Backend backend;
  const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
  sensor->Start(Config(320, 240, false));
  std::optional<Nanoseconds> previous;
  std::uint64_t previous_sequence = 0;
  for (int i = 0; i < 5; ++i) {
    const RgbdFrame frame = sensor->WaitForFrame(std::chrono::seconds(5));
    ASSERT_EQ(frame.depth_m.cols, 320);
    ASSERT_TRUE(frame.depth_timing.device_timestamp.has_value());
    EXPECT_EQ(frame.depth_timing.sequence, frame.color_timing.sequence);  // synced pair
    EXPECT_EQ(frame.depth_timing.device_timestamp, frame.color_timing.device_timestamp);
    if (previous) {
      EXPECT_GT(*frame.depth_timing.device_timestamp, *previous);
      EXPECT_GT(frame.depth_timing.sequence, previous_sequence);
    }
    previous = frame.depth_timing.device_timestamp;
    previous_sequence = frame.depth_timing.sequence;
  }
  EXPECT_LE(CheckDepth(sensor->WaitForFrame(std::chrono::seconds(5)).depth_m, -0.025).worst_m, 0.0005 + 1e-6);
  sensor->Stop();
  EXPECT_FALSE(sensor->streaming());
  EXPECT_THROW(sensor->WaitForFrame(std::chrono::milliseconds(10)), InvalidArgumentError);
}

TEST_F(OpenNI2BackendTest, UnsupportedConfigIsRejected) {
  OpenNI2Backend backend;
  const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
  try {
    sensor->Start(Config(1280, 720, false));
    FAIL() << "1280x720 is not offered";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kUnsupportedSetting);
  }
  EXPECT_FALSE(sensor->streaming());
}

TEST_F(OpenNI2BackendTest, SimDriverPropertiesThroughOpenNI) {
  OpenNI2Backend backend;  // keeps OpenNI initialised
  openni::Device device;
  ASSERT_EQ(device.open(kSimUri), openni::STATUS_OK);
  openni::VideoStream depth;
  ASSERT_EQ(depth.create(device, openni::SENSOR_DEPTH), openni::STATUS_OK);
  EXPECT_EQ(depth.getMaxPixelValue(), 10000);
  EXPECT_EQ(depth.getMinPixelValue(), 0);
  EXPECT_NEAR(depth.getHorizontalFieldOfView(), 58.0 * M_PI / 180.0, 1e-6);
  EXPECT_FALSE(depth.getMirroringEnabled());
  EXPECT_NE(depth.setMirroringEnabled(true), openni::STATUS_OK);
  ASSERT_EQ(depth.setCropping(100, 50, 200, 120), openni::STATUS_OK);
  int x = 0, y = 0, w = 0, h = 0;
  EXPECT_TRUE(depth.getCropping(&x, &y, &w, &h));
  EXPECT_EQ(x, 100);
  EXPECT_EQ(w, 200);
  ASSERT_EQ(depth.start(), openni::STATUS_OK);
  openni::VideoFrameRef frame;
  ASSERT_EQ(depth.readFrame(&frame), openni::STATUS_OK);
  EXPECT_EQ(frame.getWidth(), 200);
  EXPECT_EQ(frame.getHeight(), 120);
  EXPECT_TRUE(frame.getCroppingEnabled());
  // The cropped window holds the same depths as the full frame there.
  const auto* data = static_cast<const std::uint16_t*>(frame.getData());
  const std::optional<double> expected = SceneDepth(100 + 150, 50 + 60, 640, 480, -0.025);
  ASSERT_TRUE(expected.has_value());
  EXPECT_NEAR(data[60 * 200 + 150] * 1e-3, *expected, 0.0005 + 1e-6);
  depth.stop();
  depth.destroy();
  device.close();
}

TEST_F(OpenNI2BackendTest, RecordsToOniAndPlaysBackThroughOpenNI) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("relume-openni2-" + std::to_string(getpid()) + ".oni");
  OpenNI2Backend backend;
  {
    const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
    sensor->Start(Config(320, 240, false));
    sensor->WaitForFrame(std::chrono::seconds(5));
    sensor->StartRecording(path.string());
    EXPECT_TRUE(sensor->recording());
    for (int i = 0; i < 8; ++i) sensor->WaitForFrame(std::chrono::seconds(5));
    sensor->StopRecording();
    EXPECT_FALSE(sensor->recording());
    sensor->Stop();
  }
  ASSERT_TRUE(std::filesystem::exists(path));
  EXPECT_GT(std::filesystem::file_size(path), 1000u);
  {
    const std::unique_ptr<OpenNI2Sensor> player = backend.Open(path.string());
    EXPECT_TRUE(player->IsPlayback());
    const std::vector<RgbdStreamConfig> configs = player->SupportedConfigs();
    ASSERT_FALSE(configs.empty());
    EXPECT_EQ(configs[0].depth_width, 320);
    RgbdStreamConfig config = configs[0];
    config.register_depth_to_color = false;
    player->Start(config);
    // 8 pairs went by while recording; OpenNI2's recorder may drop a few on a loaded machine.
    EXPECT_GE(player->RecordingFrameCount(), 4);
    const RgbdFrame frame = player->WaitForFrame(std::chrono::seconds(5));
    ASSERT_EQ(frame.depth_m.cols, 320);
    const DepthCheck check = CheckDepth(frame.depth_m, -0.025);
    EXPECT_LE(check.worst_m, 0.0005 + 1e-6);  // the recording is lossless
    EXPECT_EQ(check.hole_mismatches, 0);
    player->Stop();
  }
  std::filesystem::remove(path);
  try {
    backend.Open((std::filesystem::temp_directory_path() / "relume-no-such-recording.oni").string());
    FAIL();
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kNotFound);
  }
}

// `relume session import --oni`: a recording made through OpenNI2 (registered depth) becomes a
// session whose frames sit at the stated start plus their device time, with the depth as
// recorded and the recorded geometry, ready for the SH pipeline.
TEST_F(OpenNI2BackendTest, RecordsToOniAndPlaysBackIntoASessionThroughTheCli) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("relume-oni-import-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::filesystem::path oni = dir / "rec.oni";
  {
    OpenNI2Backend backend;
    const std::unique_ptr<OpenNI2Sensor> sensor = backend.Open(kSimUri);
    ASSERT_TRUE(sensor->SupportsRegistration());
    sensor->Start(Config(320, 240, true));
    sensor->WaitForFrame(std::chrono::seconds(5));
    sensor->StartRecording(oni.string());
    for (int i = 0; i < 8; ++i) sensor->WaitForFrame(std::chrono::seconds(5));
    sensor->StopRecording();
    sensor->Stop();
  }
  // Under AddressSanitizer the CLI's leak check is off: OpenNI2's file driver leaks from its
  // playback thread, and by exit the driver is unloaded, so its frames have no module a
  // suppression could name. The import's own code is leak-checked in ImportRgbdTest.
  const std::string base = "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 " + std::string(RELUME_BINARY) +
                           " session import --oni " + oni.string() + " --site " + RELUME_SOURCE_DIR +
                           "/config/sites/athens-acropolis.yaml --out " + (dir / "s").string();
  EXPECT_NE(std::system((base + " > " + (dir / "no-start.txt").string() + " 2>&1").c_str()), 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
  // OpenNI2's .oni does not keep the registration mode: the user states it.
  ASSERT_EQ(std::system((base + " --start 2026-03-20T11:00:00Z --camera-id xtion --registered").c_str()), 0);

  const capture::SessionReader reader(dir / "s");
  const std::vector<capture::FrameRecord> frames = reader.Frames();
  ASSERT_GE(frames.size(), 6u);  // 8 pairs recorded; OpenNI2's recorder may drop some on a loaded machine
  const UtcTime start = ParseIso8601("2026-03-20T11:00:00Z").utc;
  EXPECT_EQ(frames[0].stream, "depth");
  EXPECT_EQ(frames[0].device_id, "import:xtion");
  EXPECT_EQ(frames[0].utc, start);
  // The device clock, not the playback's: pairs sit whole frame periods (1/30 s) apart, more than
  // one where the recorder dropped a pair.
  for (std::size_t i = 2; i < frames.size(); i += 2) {
    const double periods = std::chrono::duration<double>(frames[i].utc - frames[i - 2].utc).count() * 30.0;
    EXPECT_GE(periods, 0.85) << "frame pair " << i / 2;
    EXPECT_NEAR(periods, std::round(periods), 0.15) << "frame pair " << i / 2;
  }
  const DepthCheck check = CheckDepth(reader.LoadDepth(frames[0]), 0.0);
  EXPECT_GT(check.compared, 100);
  EXPECT_LE(check.worst_m, 0.0005 + 1e-6);
  const std::vector<capture::CalibrationRecord> rows = reader.Calibrations();
  const capture::CalibrationRecord* geometry = capture::RgbdGeometryAt(rows, "import:xtion", frames[0].id);
  ASSERT_NE(geometry, nullptr);
  RgbdFrame recorded;
  capture::ApplyRgbdGeometryJson(geometry->json, &recorded);
  EXPECT_TRUE(recorded.registered_to_color);
  EXPECT_EQ(recorded.color_intrinsics.width, 320);
  std::filesystem::remove_all(dir);
}

TEST_F(OpenNI2BackendTest, NoSensorGivesAClearNotFound) {
  // The simulated driver reads its device count when OpenNI initialises: no backend may be
  // alive here, so that this one initialises OpenNI afresh.
  setenv("RELUME_SIM_RGBD_DEVICES", "0", 1);
  {
    OpenNI2Backend backend;
    EXPECT_TRUE(backend.Enumerate().empty());
    try {
      backend.Open(kSimUri);
      FAIL() << "no device should be there";
    } catch (const DeviceError& error) {
      EXPECT_EQ(error.kind(), DeviceErrorKind::kNotFound);
      EXPECT_NE(std::string(error.what()).find("no devices found"), std::string::npos) << error.what();
    }
  }
  unsetenv("RELUME_SIM_RGBD_DEVICES");
}

// A real sensor through the installed OpenNI2 drivers (label "hardware").
TEST(OpenNI2HardwareTest, HardwareEnumerateAndStream) {
  OpenNI2Backend backend;
  std::vector<DeviceInfo> devices = backend.Enumerate();
  // Neither the installed Dummy driver's test device nor relume's simulated one is hardware.
  std::erase_if(devices, [](const DeviceInfo& info) {
    return info.model.find("Dummy") != std::string::npos || info.id.find("Dummy") != std::string::npos ||
           info.details.at("vendor").find("Dummy") != std::string::npos || info.details.at("vendor") == "relume";
  });
  if (devices.empty()) GTEST_SKIP() << "no RGB-D sensor attached (OpenNI2 found no devices)";
  const std::unique_ptr<RgbdSensor> sensor = backend.OpenRgbdSensor(devices[0]);
  const std::vector<RgbdStreamConfig> configs = sensor->SupportedConfigs();
  ASSERT_FALSE(configs.empty());
  sensor->Start(configs[0]);
  const RgbdFrame frame = sensor->WaitForFrame(std::chrono::seconds(5));
  EXPECT_FALSE(frame.depth_m.empty());
  sensor->Stop();
}

}  // namespace
}  // namespace relume::drivers::openni2
