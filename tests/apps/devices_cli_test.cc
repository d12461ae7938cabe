// `relume devices` through the binary: the sim backend from a rig file, and each real backend
// through its real library with the library-level simulations (libgphoto2 + simcam.so through
// CAMLIBS, libOpenNI2 + the simulated driver through LD_LIBRARY_PATH, Aravis's in-process
// Fake camera, libusb under umockdev). CTest sets the environment (tests/apps/CMakeLists.txt).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <utility>
#include <vector>

#include "capture/session.h"
#include "drivers/gphoto2/simcam/simcam_scene.h"
#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;
using testing::RunRelume;

bool Has(const testing::CliResult& r, const std::string& text) {
  return r.output.find(text) != std::string::npos;
}

// Tests of a backend this build left out skip, saying so.
#define RELUME_SKIP_UNLESS(compiled, what) \
  if (!(compiled)) GTEST_SKIP() << what << " is not part of this build"

// Every backend but the ones named, so a test sees only what it is about.
std::string Only(const std::string& backend) {
  std::string skip;
  for (const char* b : {"gphoto2", "openni2", "aravis", "usb"}) {
    if (backend != b) skip += std::string(" --skip ") + b;
  }
  return skip + " --no-gige-discovery";
}

TEST(DevicesCliTest, ListsTheRigsSimulatedDevicesWithCapabilities) {
  const auto r = RunRelume("devices --rig config/rigs/sim-outdoor.yaml" + Only("sim"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "sim: 2 devices")) << r.output;
  EXPECT_TRUE(Has(r, "sim:dslr  still_camera  model \"Sim DSLR (14-bit raw, shutter list)\"")) << r.output;
  EXPECT_TRUE(Has(r, "exposure: shutter_list, 52 speeds 1/4000 s .. 30 s")) << r.output;
  EXPECT_TRUE(Has(r, "aperture: f/2.8 .. f/22 (19 values)")) << r.output;
  EXPECT_TRUE(Has(r, "sim:rgbd  rgbd_sensor")) << r.output;
  EXPECT_TRUE(Has(r, "streams: 8")) << r.output;
  EXPECT_TRUE(Has(r, "depth 320x240 + colour 320x240 @ 30 fps, registered, synced")) << r.output;
}

TEST(DevicesCliTest, WithoutARigTheSimBackendSaysWhatToGive) {
  const auto r = RunRelume("devices" + Only("sim"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "sim: no simulated devices (--rig FILE")) << r.output;
}

TEST(DevicesCliTest, ChecksASimulatedStillCameraAndRgbdSensor) {
  auto r = RunRelume("devices --rig config/rigs/sim-outdoor.yaml --check sim:dslr" + Only("sim"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "checking sim:dslr (still_camera")) << r.output;
  EXPECT_TRUE(Has(r, "  open: ")) << r.output;
  EXPECT_TRUE(Has(r, "  capture + download: ")) << r.output;
  EXPECT_TRUE(Has(r, "frame: 640x480 rgb 14-bit, camera file tiff")) << r.output;
  EXPECT_TRUE(Has(r, "  close: ")) << r.output;
  EXPECT_TRUE(Has(r, "\nOK\n")) << r.output;

  r = RunRelume("devices --rig config/rigs/sim-outdoor.yaml --check rgbd" + Only("sim"));  // bare id
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "checking sim:rgbd (rgbd_sensor")) << r.output;
  EXPECT_TRUE(Has(r, "  start (depth 640x480 + colour 640x480 @ 30 fps, registered, synced): ")) << r.output;
  EXPECT_TRUE(Has(r, "  first frame: ")) << r.output;
  EXPECT_TRUE(Has(r, "frame: depth 640x480 (")) << r.output;
  EXPECT_TRUE(Has(r, "  stop: ")) << r.output;
  EXPECT_TRUE(Has(r, "\nOK\n")) << r.output;
}

TEST(DevicesCliTest, AnAbsentDeviceIsNamedWithWhatToDo) {
  auto r = RunRelume("devices --rig config/rigs/sim-outdoor.yaml --check sim:nope" + Only("sim"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r,
                  "relume: error: sim:nope: not found: not present; sim sees sim:dslr, sim:rgbd. Check that it "
                  "is plugged in, powered"))
      << r.output;
  r = RunRelume("devices --check sim:dslr" + Only("sim"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "sim:dslr: not found: the sim backend needs the rig that defines its devices: add --rig FILE"))
      << r.output;
  r = RunRelume("devices --check usb:04a9:3218@1-2" + Only("sim"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "USB entries are listed only")) << r.output;
}

class DevicesGphoto2Test : public ::testing::Test {
 protected:
  void SetUp() override {
    RELUME_SKIP_UNLESS(RELUME_TEST_GPHOTO2, "the gphoto2 backend");
    card_ = fs::path(::testing::TempDir()) / ("devices_cli_card_" + std::to_string(::getpid()));
    fs::remove_all(card_);
    fs::create_directories(card_);
  }
  std::string Camera() const { return "Relume Simulated DSLR@disk:" + card_.string(); }
  fs::path card_;
};

TEST_F(DevicesGphoto2Test, ListsAndChecksTheSimulatedDslrThroughLibgphoto2) {
  auto r = RunRelume("devices --gphoto2 \"" + Camera() + "\"" + Only("gphoto2"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "gphoto2: 1 device")) << r.output;
  EXPECT_TRUE(Has(r, "gphoto2:" + Camera() + "  still_camera  model \"Relume Simulated DSLR\"  serial SIM0001"))
      << r.output;
  EXPECT_TRUE(Has(r, "exposure: shutter_list, 52 speeds 1/4000 s .. 30 s")) << r.output;
  EXPECT_TRUE(Has(r, "ISO: 100 .. 6400 (7 values)")) << r.output;

  r = RunRelume("devices --check \"gphoto2:" + Camera() + "\"" + Only("gphoto2"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "frame: 240x160 rgb 16-bit, camera file tiff")) << r.output;
  EXPECT_TRUE(Has(r, "exposure 1/60 s f/8 ISO 100")) << r.output;
  EXPECT_TRUE(Has(r, "\nOK\n")) << r.output;
}

TEST_F(DevicesGphoto2Test, AnAbsentDslrIsReportedWithLibgphoto2sReason) {
  const std::string absent = "Relume Simulated DSLR@disk:" + (card_ / "unplugged").string();
  const auto r = RunRelume("devices --check \"gphoto2:" + absent + "\"" + Only("gphoto2"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "relume: error: gphoto2:" + absent + ": not found: not present (opening it: ")) << r.output;
  EXPECT_TRUE(Has(r, "gphoto2 sees no devices. Check that it is plugged in")) << r.output;
}

TEST(DevicesOpenNI2Test, ListsAndChecksTheSimulatedSensorThroughLibOpenNI2) {
  RELUME_SKIP_UNLESS(RELUME_TEST_OPENNI2, "the openni2 backend");
  auto r = RunRelume("devices" + Only("openni2"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "openni2: 1 device")) << r.output;
  EXPECT_TRUE(Has(r, "openni2:relume-sim://rgbd/0  rgbd_sensor  model \"Simulated RGB-D\"")) << r.output;
  EXPECT_TRUE(Has(r, "streams: 16")) << r.output;
  EXPECT_TRUE(Has(r, "depth 320x240 + colour 320x240 @ 30 fps, registered, synced")) << r.output;

  r = RunRelume("devices --check openni2:relume-sim://rgbd/0" + Only("openni2"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "  first frame: ")) << r.output;
  EXPECT_TRUE(Has(r, "frame: depth 640x480 (")) << r.output;
  EXPECT_TRUE(Has(r, "colour 640x480")) << r.output;
  EXPECT_TRUE(Has(r, "\nOK\n")) << r.output;
}

TEST(DevicesOpenNI2Test, NoSensorAttachedIsReportedWithOpenNI2sReason) {
  RELUME_SKIP_UNLESS(RELUME_TEST_OPENNI2, "the openni2 backend");
  setenv("RELUME_SIM_RGBD_DEVICES", "0", 1);  // the simulated driver then reports no sensor
  const auto r = RunRelume("devices --check openni2:relume-sim://rgbd/0" + Only("openni2"));
  unsetenv("RELUME_SIM_RGBD_DEVICES");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "relume: error: openni2:relume-sim://rgbd/0: not found: not present (opening it: ")) << r.output;
  EXPECT_TRUE(Has(r, "no devices found")) << r.output;
  EXPECT_TRUE(Has(r, "openni2 sees no devices")) << r.output;
}

TEST(DevicesAravisTest, ListsAndChecksAravissFakeCamera) {
  RELUME_SKIP_UNLESS(RELUME_TEST_ARAVIS, "the aravis backend");
  auto r = RunRelume("devices --aravis-fake" + Only("aravis"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "aravis: 1 device")) << r.output;
  EXPECT_TRUE(Has(r, "aravis:Fake_1  still_camera  model \"Aravis Fake\"")) << r.output;
  EXPECT_TRUE(Has(r, "exposure: continuous 10 us .. 10 s")) << r.output;

  r = RunRelume("devices --aravis-fake --check aravis:Fake_1" + Only("aravis"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "frame: 512x512 mono 8-bit")) << r.output;
  EXPECT_TRUE(Has(r, "\nOK\n")) << r.output;

  r = RunRelume("devices --check aravis:Fake_1" + Only("aravis"));  // the fake is off: absent
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "aravis:Fake_1: not found: not present; aravis sees no devices")) << r.output;
}

// A Canon DSLR (04a9:3218 on bus 1, address 5) presented to libusb by umockdev.
TEST(DevicesUsbTest, RecognisesAKnownUsbDevice) {
  RELUME_SKIP_UNLESS(RELUME_TEST_USB, "the usb backend with umockdev-run");
  const std::string command = std::string("ASAN_OPTIONS=\"${ASAN_OPTIONS}:verify_asan_link_order=0\" ") +
                              RELUME_UMOCKDEV_RUN + " --device tests/data/usb/canon-dslr.umockdev -- " + RELUME_BINARY +
                              " devices" + Only("usb");
  const auto r = testing::RunCommand(command);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "usb (known devices, listing only): 1 device")) << r.output;
  EXPECT_TRUE(Has(r, "usb:04a9:3218@1-2  still_camera  model \"Canon DSLR\"")) << r.output;
  EXPECT_TRUE(Has(r, "backend: gphoto2")) << r.output;
}

// `relume capture` with real backends: a rig naming the simulated DSLR (libgphoto2 + simcam.so)
// and the simulated RGB-D sensor (libOpenNI2 + its driver), on the host clock; then the
// recorded session played back through a `backend: playback` rig into a new session.
class CaptureRealDevicesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    RELUME_SKIP_UNLESS(RELUME_TEST_GPHOTO2 && RELUME_TEST_OPENNI2, "the gphoto2 and openni2 backends");
    root_ = fs::path(::testing::TempDir()) / ("capture_real_devices_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "card");
  }
  fs::path WriteRig(const std::string& name, const std::string& text) const {
    const fs::path path = root_ / name;
    std::ofstream(path) << text;
    return path;
  }
  std::string RealRig(const std::string& port) const {
    return "name: real\nsite: " + fs::absolute("config/sites/athens-acropolis.yaml").string() +
           "\nschedule: {count: 1}\nrgbd_burst_frames: 3\ndevices:\n"
           "  - {backend: gphoto2, model: Relume Simulated DSLR, port: \"disk:" +
           port + "\"}\n  - {backend: openni2, uri: \"relume-sim://rgbd/0\"}\n";
  }
  static std::vector<std::string> Checksums(const fs::path& session) {
    std::vector<std::string> out;
    for (const auto& f : capture::SessionReader(session).Frames()) out.push_back(f.stream + " " + f.sha256);
    return out;
  }
  fs::path root_;
};

TEST_F(CaptureRealDevicesTest, RecordsThroughTheRealLibrariesAndReplaysThroughPlayback) {
  const fs::path rig = WriteRig("real.yaml", RealRig((root_ / "card").string()));
  auto r = RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "recorded").string() + " --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "(clock system)")) << r.output;
  EXPECT_TRUE(Has(r, "1 brackets (0 partial), 3 RGB-D frames, ")) << r.output;  // faults: retries under load
  const capture::SessionReader recorded(root_ / "recorded");
  ASSERT_EQ(recorded.Devices().size(), 2u);
  EXPECT_EQ(recorded.Devices()[0].FullId(), "gphoto2:Relume Simulated DSLR@disk:" + (root_ / "card").string());
  EXPECT_EQ(recorded.Devices()[1].FullId(), "openni2:relume-sim://rgbd/0");
  int tiffs = 0;
  for (const auto& f : recorded.Frames()) tiffs += f.file_format == "tiff" && f.stream == "still" ? 1 : 0;
  EXPECT_GE(tiffs, 1);  // the camera's own 16-bit TIFF, kept byte for byte

  const fs::path replay = WriteRig("replay.yaml",
                                   "name: replay\nschedule: {count: 1}\nrgbd_burst_frames: 3\ndevices:\n"
                                   "  - {backend: playback, session: recorded, device: \"" +
                                       recorded.Devices()[0].FullId() +
                                       "\"}\n  - {backend: playback, session: recorded, device: "
                                       "\"openni2:relume-sim://rgbd/0\"}\n");
  r = RunRelume("capture --rig " + replay.string() + " --out " + (root_ / "replayed").string() + " --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(Checksums(root_ / "replayed"), Checksums(root_ / "recorded"));
}

// The field defect this guards against: a DSLR set to raw lost every frame (the writer refused
// frames without decoded pixels). Now the camera's DNG is kept byte for byte, decoded through
// LibRaw for metering, and the radiance pipeline merges the mosaics.
TEST_F(CaptureRealDevicesTest, RawFramesAreRecordedByteForByteAndProcessed) {
  const fs::path rig =
      WriteRig("raw.yaml", "name: raw\nsite: " + fs::absolute("config/sites/athens-acropolis.yaml").string() +
                               "\nschedule: {count: 1}\nrgbd_burst_frames: 2\ndevices:\n"
                               "  - {backend: gphoto2, model: Relume Simulated DSLR, port: \"disk:" +
                               (root_ / "card").string() +
                               "\", settings: {imageformat: RAW}}\n"
                               "  - {backend: openni2, uri: \"relume-sim://rgbd/0\", "
                               "stream: {depth: 320x240, color: 320x240}}\n");
  auto r = RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "raw").string() + " --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const capture::SessionReader session(root_ / "raw");
  int raw_frames = 0, depth_frames = 0;
  for (const capture::FrameRecord& f : session.Frames()) {
    if (f.stream == "still") {
      ++raw_frames;
      EXPECT_EQ(f.file_format, "dng");
      EXPECT_EQ(f.layout, ColorLayout::kBayerRggb);
      EXPECT_EQ(f.encoding, SampleEncoding::kSensorLinear);
      EXPECT_EQ(f.white_level, 16383);
    } else if (f.stream == "depth") {
      ++depth_frames;
      EXPECT_EQ(f.width, 320) << "the rig's stream: 320x240";
      EXPECT_EQ(f.file_format, "tiff");
    }
  }
  EXPECT_GE(raw_frames, 2) << r.output;
  EXPECT_EQ(depth_frames, 2);
  r = RunRelume("process " + (root_ / "raw").string() + " --pipeline radiance");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json summary = testing::ReadJsonFile(root_ / "raw" / "processed" / "radiance" / "summary.json");
  ASSERT_EQ(summary["metrics"]["brackets"].size(), 1u) << summary.dump(1);
  const fs::path exr =
      root_ / "raw" / "processed" / "radiance" / summary["metrics"]["brackets"][0]["exr"].get<std::string>();
  // The merged radiance is the simulated camera's analytic scene (simcam_scene.h) up to one
  // scale: per-pixel ratio to the truth, inside a 2-pixel border (demosaicing at the edges).
  setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);
  const cv::Mat bgr = cv::imread(exr.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(bgr.type(), CV_32FC3) << exr;
  std::vector<double> ratios;
  for (int v = 2; v < bgr.rows - 2; ++v) {
    for (int u = 2; u < bgr.cols - 2; ++u) {
      for (int c = 0; c < 3; ++c) {
        ratios.push_back(bgr.at<cv::Vec3f>(v, u)[2 - c] / drivers::simcam::SceneRadiance(u, v, c, bgr.cols, bgr.rows));
      }
    }
  }
  std::sort(ratios.begin(), ratios.end());
  const double median = ratios[ratios.size() / 2];
  const double p01 = ratios[ratios.size() / 100] / median, p99 = ratios[ratios.size() * 99 / 100] / median;
  std::cout << "raw radiance / truth: 1st percentile " << p01 << ", 99th " << p99 << " of the median\n";
  EXPECT_GT(p01, 0.993);  // measured 0.9982
  EXPECT_LT(p99, 1.007);  // measured 1.0036
}

TEST_F(CaptureRealDevicesTest, ASettingOrStreamTheDeviceDoesNotOfferStopsBeforeTheSession) {
  const std::string head = "name: bad\nsite: " + fs::absolute("config/sites/athens-acropolis.yaml").string() +
                           "\nschedule: {count: 1}\ndevices:\n";
  const std::string dslr =
      "  - {backend: gphoto2, model: Relume Simulated DSLR, port: \"disk:" + (root_ / "card").string() + "\"";
  fs::path rig = WriteRig("format.yaml", head + dslr + ", settings: {imageformat: HEIF}}\n");
  auto r = RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "format").string() + " --no-progress");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "setting imageformat = \"HEIF\" from the rig")) << r.output;
  EXPECT_TRUE(Has(r, "(the camera offers: JPEG, TIFF 16-bit, RAW)")) << r.output;
  EXPECT_FALSE(fs::exists(root_ / "format"));

  rig = WriteRig("stream.yaml", head + "  - {backend: openni2, uri: \"relume-sim://rgbd/0\", stream: {fps: 60}}\n");
  r = RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "stream").string() + " --no-progress");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "offers no stream with 60 fps; change `stream:` in the rig to one it offers:")) << r.output;
  EXPECT_TRUE(Has(r, "depth 320x240 + colour 320x240 @ 30 fps")) << r.output;
  EXPECT_FALSE(fs::exists(root_ / "stream"));

  rig = WriteRig("camera-stream.yaml", head + dslr + ", stream: {fps: 30}}\n");
  r = RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "cs").string() + " --no-progress");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "for RGB-D sensors (`backend: openni2` or `playback`) only")) << r.output;
}

TEST_F(CaptureRealDevicesTest, AnOpenNi2SessionIsRelitFromItsOwnRecordedGeometry) {
  // No simulated device spec and no world: the SH pipeline takes the colour intrinsics from
  // the session's rgbd_geometry row, the light in the camera frame, colour as sRGB.
  const std::string head = "name: kinect\nsite: " + fs::absolute("config/sites/athens-acropolis.yaml").string() +
                           "\nschedule: {count: 1}\nrgbd_burst_frames: 3\ndevices:\n"
                           "  - {backend: openni2, uri: \"relume-sim://rgbd/0\", stream: {depth: 320x240, color: "
                           "320x240, fps: 30, registered: ";
  const fs::path registered = WriteRig("registered.yaml", head + "true}}\n");
  auto r =
      RunRelume("capture --rig " + registered.string() + " --out " + (root_ / "kinect").string() + " --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunRelume("process " + (root_ / "kinect").string() + " --pipeline sh");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "colour intrinsics from the session's rgbd_geometry row")) << r.output;
  EXPECT_TRUE(Has(r, "assuming the sRGB transfer curve")) << r.output;
  EXPECT_TRUE(Has(r, "unknown: k-means segments")) << "no world, so no known albedo: " << r.output;
  const fs::path out = root_ / "kinect" / "processed" / "sh";
  const nlohmann::json summary = testing::ReadJsonFile(out / "summary.json");
  EXPECT_FALSE(summary["metrics"].contains("relit_relative_rms_mean")) << "no truth to compare with";
  int relit = 0;
  for (const nlohmann::json& o : summary["outputs"]) {
    EXPECT_TRUE(fs::exists(out / o["path"].get<std::string>())) << o;
    relit += o["path"].get<std::string>().ends_with("relit.exr");
  }
  EXPECT_EQ(relit, 2);  // frames 1 and 2 relit to frame 3's light
  for (const nlohmann::json& f : summary["metrics"]["frames"]) {
    EXPECT_TRUE(f["fit"]["usable"]) << f;
    EXPECT_TRUE(f["fit"].contains("clipped_pixels")) << "the sRGB path marks clipped codes too: " << f;
  }
  // No truth, but a static view: the relit frames against frame 3's photograph.
  EXPECT_EQ(summary["metrics"]["destination_photo_frames"], 2) << summary["metrics"].dump(1);
  EXPECT_LT(summary["metrics"]["destination_photo_relative_rms_median"].get<double>(), 0.1);

  // Depth not registered to colour: the pipeline registers it with the recorded geometry.
  const fs::path unregistered = WriteRig("unregistered.yaml", head + "false}}\n");
  r = RunRelume("capture --rig " + unregistered.string() + " --out " + (root_ / "unregistered").string() +
                " --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunRelume("process " + (root_ / "unregistered").string() + " --pipeline sh");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Has(r, "was recorded unregistered")) << r.output;
  const nlohmann::json registered_here =
      testing::ReadJsonFile(root_ / "unregistered" / "processed" / "sh" / "summary.json");
  for (const nlohmann::json& f : registered_here["metrics"]["frames"]) EXPECT_TRUE(f["fit"]["usable"]) << f;
}

TEST_F(CaptureRealDevicesTest, MalformedStreamsSettingsAndFormatsNameTheirLineAndKey) {
  const std::string head = "name: bad\nsite: " + fs::absolute("config/sites/athens-acropolis.yaml").string() + "\n";
  const std::string sensor = "devices:\n  - {backend: openni2, uri: \"relume-sim://rgbd/0\"";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {head + sensor + ", stream: {depth: 640by480}}\n", "stream.depth: expected WIDTHxHEIGHT"},
      {head + sensor + ", stream: {synced: maybe}}\n", "stream.synced: expected true or false"},
      {head + sensor + ", stream: {fps: 30, size: 2}}\n", "size"},
      {head + sensor + ", settings: {iso: \"100\"}}\n", "camera settings are for `backend: gphoto2` cameras only"},
      {head + "rgbd_format: jpeg\n" + sensor + "}\n", "unknown RGB-D file format 'jpeg'"},
      {head + "rgbd_depth: inches\n" + sensor + "}\n", "unknown depth unit 'inches'"},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const fs::path rig = WriteRig("malformed" + std::to_string(i) + ".yaml", cases[i].first);
    const fs::path out = root_ / ("malformed" + std::to_string(i));
    const auto r = RunRelume("capture --rig " + rig.string() + " --out " + out.string() + " --no-progress");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_TRUE(Has(r, cases[i].second)) << cases[i].first << " -> " << r.output;
    EXPECT_TRUE(Has(r, rig.string())) << "the message names the rig file: " << r.output;
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST_F(CaptureRealDevicesTest, AnAbsentDeviceStopsTheCaptureWithWhatToDo) {
  const fs::path rig = WriteRig("absent.yaml", RealRig((root_ / "unplugged").string()));
  const auto r =
      RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "absent").string() + " --no-progress");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "relume: error: gphoto2 device (model \"Relume Simulated DSLR\", port \"disk:" +
                         (root_ / "unplugged").string() +
                         "\") at line 6: not found: not present; gphoto2 sees no devices"))
      << r.output;
  EXPECT_TRUE(Has(r, "Check that it is plugged in, powered")) << r.output;
  EXPECT_FALSE(fs::exists(root_ / "absent")) << "no session folder for a capture that cannot start";
}

TEST_F(CaptureRealDevicesTest, RigsCannotMixSimulatedAndRealDevices) {
  const fs::path rig =
      WriteRig("mixed.yaml", "name: mixed\nscene: " + fs::absolute("config/scenes/outdoor-building.yaml").string() +
                                 "\ndevices:\n  - {id: cam, kind: still_camera}\n"
                                 "  - {backend: openni2, uri: \"relume-sim://rgbd/0\"}\n");
  const auto r = RunRelume("capture --rig " + rig.string() + " --out " + (root_ / "mixed").string() + " --no-progress");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Has(r, "a rig cannot mix simulated and real devices")) << r.output;
}

}  // namespace
}  // namespace relume
