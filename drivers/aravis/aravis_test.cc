// End-to-end tests of the aravis backend through the real Aravis library, with no hardware:
// Aravis's in-process fake camera ("Fake_1", painted from an analytic radiance ramp) and
// Aravis's GigE Vision fake camera (arv-fake-gv-camera-0.8) on 127.0.0.1. GigE broadcast
// discovery is never used: the loopback camera is probed by unicast only.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

extern "C" {
#include <arv.h>
}

#include <chrono>
#include <cstring>
#include <filesystem>
#include <opencv2/core.hpp>
#include <thread>

#include "drivers/aravis/aravis_backend.h"
#include "drivers/aravis/fake_radiance_painter.h"
#include "drivers/aravis/pixel_formats.h"

namespace relume::drivers::aravis {
namespace {

using testing::FakePainterOptions;
using testing::FakeRadiancePainter;
using testing::RadianceRampTruth;

AravisBackendOptions FakeOnly() {
  AravisBackendOptions options;
  options.gige_discovery = false;
  options.usb3 = false;
  options.fake = true;
  options.camera.raw_gain_db_per_step = 1.0;
  return options;
}

// Fake_1 with a small region, a fast frame rate and the ramp painted into it.
struct FakeRig {
  explicit FakeRig(const std::string& pixel_format = "Mono16", int width = 64, int height = 48) {
    AravisBackend backend(FakeOnly());
    DeviceInfo wanted;
    wanted.backend = "aravis";
    wanted.id = "Fake_1";
    camera = backend.OpenCamera(wanted);
    camera->SetRegion(0, 0, width, height);
    camera->SetPixelFormat(pixel_format);
    camera->SetFrameRate(500.0);
    FakePainterOptions options;
    options.counts_per_radiance_second = 1000.0;
    options.raw_gain_db_per_step = 1.0;
    painter = std::make_unique<FakeRadiancePainter>(truth, options);
    painter->Install(camera->native_device());
  }
  ~FakeRig() { painter.reset(); }
  // 10 .. 10 + 0.5 * 64 + 0.25 * 48 W m^-2 sr^-1 across the image.
  std::shared_ptr<RadianceRampTruth> truth = std::make_shared<RadianceRampTruth>(10.0, 0.5, 0.25);
  std::unique_ptr<AravisCamera> camera;
  std::unique_ptr<FakeRadiancePainter> painter;
};

double Mean(const CameraImage& image) {
  return cv::mean(image.pixels)[0];
}

TEST(AravisFakeTest, EnumeratesTheInProcessFakeCamera) {
  const std::vector<DeviceInfo> devices = ListAravisDevices(FakeOnly());
  ASSERT_EQ(devices.size(), 1u);
  EXPECT_EQ(devices[0].backend, "aravis");
  EXPECT_EQ(devices[0].id, "Fake_1");
  EXPECT_EQ(devices[0].kind, DeviceKind::kStillCamera);
  EXPECT_FALSE(devices[0].serial.empty());
  EXPECT_EQ(devices[0].details.at("protocol"), "Fake");
}

TEST(AravisFakeTest, OpensBySerialAndRejectsUnknownDevices) {
  AravisBackend backend(FakeOnly());
  const DeviceInfo listed = backend.Enumerate().at(0);
  DeviceInfo by_serial;
  by_serial.backend = "aravis";
  by_serial.serial = listed.serial;
  EXPECT_EQ(backend.OpenCamera(by_serial)->info().id, "Fake_1");
  DeviceInfo missing;
  missing.backend = "aravis";
  missing.id = "no-such-camera";
  try {
    backend.OpenCamera(missing);
    FAIL() << "opened a camera that does not exist";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kNotFound);
    EXPECT_NE(std::string(e.what()).find("aravis:Fake_1"), std::string::npos) << e.what();
  }
  DeviceInfo rgbd = listed;
  rgbd.kind = DeviceKind::kRgbdSensor;
  EXPECT_THROW(backend.OpenRgbdSensor(rgbd), InvalidArgumentError);
}

TEST(AravisFakeTest, RegistryFindsAndOpensTheFakeByFullId) {
  DeviceRegistry registry;
  registry.Add(std::make_shared<AravisBackend>(FakeOnly()));
  const DeviceInfo info = registry.Find("aravis:Fake_1");
  std::unique_ptr<StillCamera> camera = registry.OpenStillCamera(info);
  EXPECT_EQ(camera->info().FullId(), "aravis:Fake_1");
  EXPECT_EQ(camera->capabilities().control, ExposureControl::kContinuous);
}

TEST(AravisFakeTest, CapabilitiesComeFromTheCameraBounds) {
  FakeRig rig;
  const ExposureCapabilities caps = rig.camera->capabilities();
  EXPECT_EQ(caps.control, ExposureControl::kContinuous);
  EXPECT_DOUBLE_EQ(caps.min_exposure_time_s, 10e-6);  // ExposureTimeAbs 10 us .. 10 s
  EXPECT_DOUBLE_EQ(caps.max_exposure_time_s, 10.0);
  EXPECT_DOUBLE_EQ(caps.min_gain_db, 0.0);  // GainRaw 0..10 at 1 dB per step
  EXPECT_DOUBLE_EQ(caps.max_gain_db, 10.0);
}

TEST(AravisFakeTest, CountsMatchTheRadianceRampAtEveryPixel) {
  FakeRig rig;
  ExposureSettings settings;
  settings.exposure_time_s = 0.002;
  settings.gain_db = 0.0;
  rig.camera->Apply(settings);
  const StillFrame frame = rig.camera->Capture();
  const CameraImage& image = frame.image;
  std::string why;
  ASSERT_TRUE(image.IsValid(&why)) << why;
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  EXPECT_EQ(image.layout, ColorLayout::kMono);
  EXPECT_EQ(image.encoding, SampleEncoding::kSensorLinear);
  EXPECT_EQ(image.bits_per_sample, 16);
  EXPECT_EQ(image.white_level, 65535);
  EXPECT_DOUBLE_EQ(frame.exposure.exposure_time_s, 0.002);
  int mismatches = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const double radiance = rig.truth->RadianceAt(x + 0.5, y + 0.5);
      const double expected = std::round(radiance * 0.002 * 1000.0);  // counts model, unit gain
      mismatches += std::abs(image.pixels.at<std::uint16_t>(y, x) - expected) > 0.5;
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(AravisFakeTest, ExposureAndGainScaleTheCounts) {
  FakeRig rig;
  ExposureSettings base;
  base.exposure_time_s = 0.01;
  base.gain_db = 0.0;
  rig.camera->Apply(base);
  const double at_10ms = Mean(rig.camera->Capture().image);
  ExposureSettings longer;
  longer.exposure_time_s = 0.04;
  rig.camera->Apply(longer);
  const double at_40ms = Mean(rig.camera->Capture().image);
  EXPECT_NEAR(at_40ms / at_10ms, 4.0, 1e-3);
  ExposureSettings gain;
  gain.gain_db = 6.0;
  rig.camera->Apply(gain);
  const StillFrame gained = rig.camera->Capture();
  EXPECT_DOUBLE_EQ(gained.exposure.gain_db, 6.0);
  EXPECT_NEAR(Mean(gained.image) / at_40ms, std::pow(10.0, 6.0 / 20.0), 1e-3);
}

TEST(AravisFakeTest, OutOfRangeSettingsThrowAndChangeNothing) {
  FakeRig rig;
  ExposureSettings good;
  good.exposure_time_s = 0.005;
  rig.camera->Apply(good);
  for (double t : {5e-6, 11.0, std::nan("")}) {
    ExposureSettings bad;
    bad.exposure_time_s = t;
    bad.gain_db = 3.0;
    try {
      rig.camera->Apply(bad);
      FAIL() << "accepted exposure " << t;
    } catch (const DeviceError& e) {
      EXPECT_EQ(e.kind(), DeviceErrorKind::kUnsupportedSetting);
    }
  }
  ExposureSettings bad_gain;
  bad_gain.gain_db = 11.0;
  EXPECT_THROW(rig.camera->Apply(bad_gain), DeviceError);
  ExposureSettings iso;
  iso.iso = 100;
  EXPECT_THROW(rig.camera->Apply(iso), DeviceError);
  EXPECT_DOUBLE_EQ(rig.camera->exposure_time_s(), 0.005);
  EXPECT_DOUBLE_EQ(rig.camera->gain_db(), 0.0);
}

TEST(AravisFakeTest, GainRawWithoutAScaleCannotBeSetInDecibels) {
  AravisBackendOptions options = FakeOnly();
  options.camera.raw_gain_db_per_step = 0.0;
  AravisBackend backend(options);
  DeviceInfo wanted;
  wanted.id = "Fake_1";
  const auto camera = backend.OpenCamera(wanted);
  EXPECT_EQ(camera->capabilities().max_gain_db, 0.0);
  ExposureSettings gain;
  gain.gain_db = 0.0;
  try {
    camera->Apply(gain);
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kUnsupportedSetting);
    EXPECT_NE(std::string(e.what()).find("raw_gain_db_per_step"), std::string::npos);
  }
}

TEST(AravisFakeTest, BracketIsMonotonicAndSaturatesAtTheWhiteLevel) {
  FakeRig rig("Mono8");
  const std::vector<double> times = {0.0005, 0.001, 0.002, 0.004, 0.008, 0.016, 0.032};
  const std::vector<StillFrame> bracket = rig.camera->CaptureBracket(times);
  ASSERT_EQ(bracket.size(), times.size());
  double previous = -1.0;
  for (std::size_t i = 0; i < bracket.size(); ++i) {
    EXPECT_DOUBLE_EQ(bracket[i].exposure.exposure_time_s, times[i]);
    const double mean = Mean(bracket[i].image);
    EXPECT_GE(mean, previous) << "exposure " << times[i];
    previous = mean;
    // The brightest pixel of the ramp follows the model, clipped at 255.
    const double radiance = rig.truth->RadianceAt(63.5, 47.5);
    EXPECT_EQ(bracket[i].image.pixels.at<std::uint8_t>(47, 63),
              rig.painter->ExpectedCounts(radiance, times[i], 0, 255));
  }
  EXPECT_EQ(bracket.back().image.pixels.at<std::uint8_t>(47, 63), 255);  // 53.5 * 0.032 * 1000 clips
  EXPECT_DOUBLE_EQ(rig.camera->exposure_time_s(), 0.01);                 // the fake's default, restored
}

TEST(AravisFakeTest, PixelFormatsGiveLayoutAndBitDepth) {
  struct Case {
    const char* format;
    ColorLayout layout;
    int type;
  };
  for (const Case& c : {Case{"Mono8", ColorLayout::kMono, CV_8UC1}, Case{"BayerRG8", ColorLayout::kBayerRggb, CV_8UC1},
                        Case{"BayerBG8", ColorLayout::kBayerBggr, CV_8UC1}, Case{"RGB8", ColorLayout::kRgb, CV_8UC3},
                        Case{"Mono16", ColorLayout::kMono, CV_16UC1}}) {
    FakeRig rig(c.format, 32, 16);
    ExposureSettings settings;
    settings.exposure_time_s = 0.004;
    rig.camera->Apply(settings);
    const CameraImage image = rig.camera->Capture().image;
    std::string why;
    EXPECT_TRUE(image.IsValid(&why)) << c.format << ": " << why;
    EXPECT_EQ(image.layout, c.layout) << c.format;
    EXPECT_EQ(image.pixels.type(), c.type) << c.format;
    EXPECT_EQ(image.encoding, SampleEncoding::kSensorLinear);
    const double expected = std::round(rig.truth->RadianceAt(0.5, 0.5) * 0.004 * 1000.0);
    EXPECT_EQ(
        image.pixels.ptr<std::uint8_t>(0)[0] + (c.type == CV_16UC1 ? 256 * image.pixels.ptr<std::uint8_t>(0)[1] : 0),
        expected)
        << c.format;
  }
}

TEST(AravisFakeTest, UnknownPixelFormatIsUnsupported) {
  FakeRig rig;
  try {
    rig.camera->SetPixelFormat("YUV422Packed");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kUnsupportedSetting);
    EXPECT_NE(std::string(e.what()).find("Mono8"), std::string::npos) << e.what();
  }
}

TEST(AravisFakeTest, StreamingUnwrapsFrameIdsAndMapsTimestampsToHostTime) {
  FakeRig rig("Mono8", 32, 16);
  rig.camera->SetFrameRate(1000.0);
  rig.camera->StartStreaming();
  std::uint64_t previous_sequence = 0;
  std::uint64_t previous_raw = 0;
  bool saw_raw_wrap = false;
  // The fake's counter starts at 65400, so 200 frames cross 65535 -> 1.
  for (int i = 0; i < 200; ++i) {
    const StreamFrame f = rig.camera->WaitForFrame(std::chrono::seconds(2));
    ASSERT_LT(f.raw_frame_id, 65536u);
    ASSERT_NE(f.raw_frame_id, 0u);
    if (i > 0) {
      EXPECT_EQ(f.frame.timing.sequence, previous_sequence + 1 + f.frames_lost_before);
      saw_raw_wrap = saw_raw_wrap || f.raw_frame_id < previous_raw;
    }
    ASSERT_TRUE(f.frame.timing.device_timestamp.has_value());
    if (i >= 20) {
      // The fake stamps frames with the host's real-time clock: the fitted map must agree
      // with the host time of the same buffer to within the jitter the fit removes.
      ASSERT_TRUE(f.device_time_in_host_utc.has_value()) << rig.camera->clock_fit().reason;
      const auto error = *f.device_time_in_host_utc - f.frame.timing.host_utc;
      EXPECT_LT(std::chrono::abs(error), std::chrono::milliseconds(1));
    }
    previous_sequence = f.frame.timing.sequence;
    previous_raw = f.raw_frame_id;
  }
  rig.camera->StopStreaming();
  EXPECT_TRUE(saw_raw_wrap);
  const StreamStatistics stats = rig.camera->statistics();
  EXPECT_GE(stats.wraps, 1u);
  EXPECT_EQ(stats.delivered, 200u);
  EXPECT_TRUE(rig.camera->clock_fit().usable);
  EXPECT_NEAR(rig.camera->clock_fit().drift_ppm, 0.0, 100.0);
  EXPECT_THROW(rig.camera->WaitForFrame(std::chrono::milliseconds(10)), InvalidArgumentError);
}

TEST(AravisErrorsTest, GErrorsMapOntoDeviceErrorKinds) {
  struct Case {
    GQuark domain;
    int code;
    DeviceErrorKind kind;
  };
  const Case cases[] = {
      {arv_device_error_quark(), ARV_DEVICE_ERROR_TIMEOUT, DeviceErrorKind::kTimeout},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_TRANSFER_ERROR, DeviceErrorKind::kIo},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_NOT_FOUND, DeviceErrorKind::kNotFound},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_NOT_CONTROLLER, DeviceErrorKind::kAccessDenied},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_PROTOCOL_ERROR_ACCESS_DENIED, DeviceErrorKind::kAccessDenied},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_PROTOCOL_ERROR_BUSY, DeviceErrorKind::kBusy},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_NOT_CONNECTED, DeviceErrorKind::kDisconnected},
      {arv_device_error_quark(), ARV_DEVICE_ERROR_FEATURE_NOT_FOUND, DeviceErrorKind::kUnsupportedSetting},
      {arv_gc_error_quark(), ARV_GC_ERROR_OUT_OF_RANGE, DeviceErrorKind::kUnsupportedSetting},
      {g_io_error_quark(), G_IO_ERROR_TIMED_OUT, DeviceErrorKind::kTimeout},
      {g_io_error_quark(), G_IO_ERROR_PERMISSION_DENIED, DeviceErrorKind::kAccessDenied},
      {g_io_error_quark(), G_IO_ERROR_NOT_FOUND, DeviceErrorKind::kNotFound},
      {g_io_error_quark(), G_IO_ERROR_HOST_UNREACHABLE, DeviceErrorKind::kDisconnected},
      {g_io_error_quark(), G_IO_ERROR_FAILED, DeviceErrorKind::kIo},
  };
  for (const Case& c : cases) {
    GError* error = g_error_new_literal(c.domain, c.code, "x");
    EXPECT_EQ(KindFromGError(error), c.kind) << g_quark_to_string(c.domain) << " " << c.code;
    try {
      ThrowIfGError(error, "aravis:cam", "doing");  // frees error
      FAIL();
    } catch (const DeviceError& e) {
      EXPECT_EQ(e.kind(), c.kind);
      EXPECT_EQ(std::string(e.what()), std::string("aravis:cam: ") + ToString(c.kind) + ": doing: x");
    }
  }
  EXPECT_NO_THROW(ThrowIfGError(nullptr, "aravis:cam", "doing"));
}

TEST(PixelFormatsTest, RowPaddingIsSkippedAndBgrBecomesRgb) {
  const std::uint8_t bgr[] = {1, 2, 3, 4, 5, 6, 99, 99, 7, 8, 9, 10, 11, 12, 99, 99};  // 2x2, 2 bytes padding
  const CameraImage image = ImageFromPixels(bgr, sizeof(bgr), 0x02180015u, 2, 2, 2, "cam");
  EXPECT_EQ(image.pixels.at<cv::Vec3b>(0, 0), cv::Vec3b(3, 2, 1));
  EXPECT_EQ(image.pixels.at<cv::Vec3b>(1, 1), cv::Vec3b(12, 11, 10));
  const std::uint16_t mono12[] = {0, 4095, 17, 2048};
  const CameraImage twelve = ImageFromPixels(mono12, sizeof(mono12), FindPixelFormat("Mono12")->pfnc, 2, 2, 0, "cam");
  EXPECT_EQ(twelve.bits_per_sample, 12);
  EXPECT_EQ(twelve.white_level, 4095);
  EXPECT_EQ(twelve.pixels.at<std::uint16_t>(1, 0), 17);
}

TEST(PixelFormatsTest, ShortBuffersAndUnknownFormatsAreErrors) {
  const std::uint8_t data[3] = {};
  try {
    ImageFromPixels(data, sizeof(data), FindPixelFormat("Mono8")->pfnc, 2, 2, 0, "cam");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kCorruptFrame);
  }
  try {
    ImageFromPixels(data, sizeof(data), 0x010c0004u /* Mono10Packed */, 1, 1, 0, "cam");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kUnsupportedSetting);
  }
}

// --- GigE Vision on loopback -------------------------------------------------------------

std::string FakeGvCameraPath() {
  const std::string configured = RELUME_ARV_FAKE_GV_CAMERA;
  if (!configured.empty() && std::filesystem::exists(configured)) return configured;
  for (const char* dir : {"/usr/bin", "/usr/local/bin"}) {
    const std::string path = std::string(dir) + "/arv-fake-gv-camera-0.8";
    if (std::filesystem::exists(path)) return path;
  }
  return "";
}

// Runs arv-fake-gv-camera-0.8 on 127.0.0.1 for the lifetime of the object.
class FakeGvCameraProcess {
 public:
  FakeGvCameraProcess(const std::string& path, const std::string& serial) {
    pid_ = fork();
    if (pid_ == 0) {
      execl(path.c_str(), path.c_str(), "-i", "127.0.0.1", "-s", serial.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~FakeGvCameraProcess() { Kill(); }
  bool running() {
    if (pid_ <= 0) return false;
    int status = 0;
    return waitpid(pid_, &status, WNOHANG) == 0;
  }
  void Kill() {
    if (pid_ <= 0) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
};

AravisBackendOptions LoopbackOnly() {
  AravisBackendOptions options;
  options.gige_discovery = false;  // no broadcasts: traffic to 127.0.0.1 only
  options.usb3 = false;
  options.fake = false;
  options.gige_addresses = {"127.0.0.1"};
  options.camera.frame_timeout = std::chrono::seconds(2);
  return options;
}

std::optional<DeviceInfo> WaitForLoopbackCamera(const std::string& serial) {
  for (int attempt = 0; attempt < 20; ++attempt) {
    for (const DeviceInfo& d : ListAravisDevices(LoopbackOnly())) {
      if (d.serial == serial) return d;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return std::nullopt;
}

TEST(AravisGigELoopbackTest, EnumeratesCapturesAndNoticesTheCameraGoingAway) {
  const std::string path = FakeGvCameraPath();
  if (path.empty()) GTEST_SKIP() << "arv-fake-gv-camera-0.8 is not installed (Debian package aravis-tools)";
  const std::string serial = "RELUME" + std::to_string(getpid());
  FakeGvCameraProcess process(path, serial);
  const std::optional<DeviceInfo> info = WaitForLoopbackCamera(serial);
  ASSERT_TRUE(info.has_value()) << "the GigE fake on 127.0.0.1 did not answer (port 3956 taken by another process?)";
  EXPECT_EQ(info->address, "127.0.0.1");
  EXPECT_EQ(info->details.at("protocol"), "GigEVision");
  EXPECT_EQ(info->id, "Aravis-Fake-" + serial);

  AravisBackend backend(LoopbackOnly());
  std::unique_ptr<AravisCamera> camera = backend.OpenCamera(*info);
  camera->SetRegion(0, 0, 128, 64);
  camera->SetPixelFormat("Mono8");
  ExposureSettings settings;
  settings.exposure_time_s = 0.01;  // with GainRaw 0 the fake's ramp has unit scale
  camera->Apply(settings);
  const StillFrame frame = camera->Capture();
  ASSERT_EQ(frame.image.width(), 128);
  ASSERT_EQ(frame.image.height(), 64);
  EXPECT_EQ(frame.image.layout, ColorLayout::kMono);
  // Aravis's GigE fake paints (x + y + frame id) mod 255: a diagonal ramp.
  int off_ramp = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 1; x < 128; ++x) {
      const int left = frame.image.pixels.at<std::uint8_t>(y, x - 1);
      const int here = frame.image.pixels.at<std::uint8_t>(y, x);
      off_ramp += here != (left + 1) % 255;
    }
  }
  EXPECT_EQ(off_ramp, 0);
  EXPECT_TRUE(frame.timing.device_timestamp.has_value());
  EXPECT_LT(std::chrono::abs(UtcNow() - frame.timing.host_utc), std::chrono::seconds(5));

  // Unplug: the process dies, Aravis's heartbeat (every 1 s, retried for 5 s) fails and it
  // emits control-lost. Wait for it without sending commands that would compete with the
  // heartbeat for the control channel.
  process.Kill();
  const MonotonicTime give_up = MonotonicNow() + std::chrono::seconds(40);
  while (!camera->control_lost() && MonotonicNow() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(camera->control_lost()) << "control-lost was not signalled within 40 s";
  try {
    camera->Capture();
    FAIL() << "captured from a camera that is gone";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceErrorKind::kDisconnected) << e.what();
  }
  EXPECT_TRUE(camera->control_lost());
}

}  // namespace
}  // namespace relume::drivers::aravis
