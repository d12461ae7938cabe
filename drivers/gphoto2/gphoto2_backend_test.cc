// End-to-end tests of the gphoto2 backend through the real libgphoto2, against simcam.so (the
// simulated DSLR camera driver in simcam/). CTest sets CAMLIBS to the folder holding only
// simcam.so, IOLIBS to the installed port drivers and HOME to a scratch folder. Tests named
// Hardware* use the installed camera drivers and skip when no camera is attached.
#include "drivers/gphoto2/gphoto2_backend.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "drivers/retry.h"

namespace relume::drivers::gphoto2 {
namespace {

constexpr const char* kSimModel = "Relume Simulated DSLR";

// The simulated camera's picture, written out here from its documented definition
// (docs/backends-gphoto2-openni2.md): fraction of full scale at pixel (u, v), channel c.
double ExpectedSignal(int u, int v, int c, double time_s, double aperture_f, double iso, double ev) {
  const double gain[3] = {1.0, 0.8, 0.6};
  const double x = (u + 0.5) / 240.0;
  const double y = (v + 0.5) / 160.0;
  const double radiance = gain[c] * std::pow(2.0, -6.0 * x) * (0.75 + 0.25 * std::cos(6.0 * M_PI * y));
  return std::min(1.0, radiance * time_s * 60.0 * iso / 100.0 * std::pow(8.0 / aperture_f, 2.0) * std::pow(2.0, ev));
}

ExposureSettings Settings(std::optional<double> exposure_time_s, std::optional<double> ev_compensation = std::nullopt,
                          std::optional<double> aperture_f = std::nullopt, std::optional<double> iso = std::nullopt,
                          std::optional<double> gain_db = std::nullopt) {
  ExposureSettings settings;
  settings.exposure_time_s = exposure_time_s;
  settings.ev_compensation = ev_compensation;
  settings.aperture_f = aperture_f;
  settings.iso = iso;
  settings.gain_db = gain_db;
  return settings;
}

class Gphoto2BackendTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::getenv("CAMLIBS") == nullptr) GTEST_SKIP() << "CAMLIBS is not set: run through ctest";
    const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    folder_ = std::filesystem::temp_directory_path() / ("relume-simcam-" + test + "-" + std::to_string(getpid()));
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
  }
  void TearDown() override {
    if (!folder_.empty()) std::filesystem::remove_all(folder_);
  }
  GPhoto2CameraAddress Address() const { return {kSimModel, "disk:" + folder_.string()}; }
  GPhoto2BackendOptions Options() const {
    GPhoto2BackendOptions options;
    options.autodetect = false;
    options.configured = {Address()};
    return options;
  }
  void Faults(const std::string& lines) const { std::ofstream(folder_ / "simcam-faults") << lines; }

  std::filesystem::path folder_;
};

TEST_F(Gphoto2BackendTest, LoadsTheSimulatedCameraDriverThroughCamlibs) {
  GPhoto2Backend backend(Options());
  const std::vector<std::string> models = backend.SupportedModels();
  ASSERT_EQ(models.size(), 1u);  // CAMLIBS holds only simcam.so
  EXPECT_EQ(models[0], kSimModel);
}

TEST_F(Gphoto2BackendTest, EnumeratesConfiguredCameraThatAnswers) {
  GPhoto2BackendOptions options = Options();
  options.configured.push_back({kSimModel, "disk:" + (folder_ / "absent").string()});
  GPhoto2Backend backend(options);
  const std::vector<DeviceInfo> devices = backend.Enumerate();
  ASSERT_EQ(devices.size(), 1u);
  EXPECT_EQ(devices[0].backend, "gphoto2");
  EXPECT_EQ(devices[0].model, kSimModel);
  EXPECT_EQ(devices[0].address, Address().port);
  EXPECT_EQ(devices[0].serial, "SIM0001");
  EXPECT_EQ(devices[0].id, std::string(kSimModel) + "@" + Address().port);
  EXPECT_EQ(devices[0].details.at("source"), "configured");
  // And what was enumerated opens.
  const std::unique_ptr<StillCamera> camera = backend.OpenStillCamera(devices[0]);
  EXPECT_EQ(camera->info().FullId(), devices[0].FullId());
}

TEST_F(Gphoto2BackendTest, AutodetectDoesNotInventCameras) {
  GPhoto2BackendOptions options;
  options.autodetect = true;  // no USB camera here, and disk ports are not autodetected
  GPhoto2Backend backend(options);
  // Only mounted folders with a DCIM directory could show up (as "Mass Storage Camera").
  for (const DeviceInfo& info : backend.Enumerate()) {
    EXPECT_NE(info.model, kSimModel);
    EXPECT_EQ(info.details.at("source"), "autodetected");
  }
}

TEST_F(Gphoto2BackendTest, ReadsCapabilitiesFromTheConfigTree) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  const ExposureCapabilities caps = camera->capabilities();
  EXPECT_EQ(caps.control, ExposureControl::kShutterList);
  ASSERT_EQ(caps.shutter_speeds_s.size(), 52u);  // 1/4000 .. 30 s in third stops, "bulb" skipped
  EXPECT_DOUBLE_EQ(caps.shutter_speeds_s.front(), 1.0 / 4000.0);
  EXPECT_DOUBLE_EQ(caps.shutter_speeds_s.back(), 30.0);
  EXPECT_TRUE(std::is_sorted(caps.shutter_speeds_s.begin(), caps.shutter_speeds_s.end()));
  EXPECT_DOUBLE_EQ(caps.apertures_f.front(), 2.8);
  EXPECT_DOUBLE_EQ(caps.apertures_f.back(), 22.0);
  EXPECT_EQ(caps.iso_values, (std::vector<double>{100, 200, 400, 800, 1600, 3200, 6400}));
  ASSERT_EQ(caps.ev_steps.size(), 19u);
  EXPECT_DOUBLE_EQ(caps.ev_steps.front(), -3.0);
  EXPECT_DOUBLE_EQ(caps.ev_steps.back(), 3.0);
  const std::vector<std::string> names = camera->ConfigNames();
  for (const char* name : {"shutterspeed", "aperture", "iso", "exposurecompensation", "capturetarget"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  }
}

TEST_F(Gphoto2BackendTest, CapturesTiffMatchingTheAnalyticExposure) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  camera->Apply(Settings(1.0 / 125.0, std::nullopt, 8.0, 100.0));
  const StillFrame frame = camera->Capture();
  EXPECT_EQ(frame.original_format, "tiff");
  ASSERT_GE(frame.original_file.size(), 4u);
  EXPECT_EQ(frame.original_file[0], 'I');  // little-endian TIFF: "II*\0"
  EXPECT_EQ(frame.original_file[2], 42);
  ASSERT_EQ(frame.image.pixels.type(), CV_16UC3);
  EXPECT_EQ(frame.image.width(), 240);
  EXPECT_EQ(frame.image.height(), 160);
  EXPECT_EQ(frame.image.bits_per_sample, 16);
  std::string why;
  EXPECT_TRUE(frame.image.IsValid(&why)) << why;
  EXPECT_DOUBLE_EQ(frame.exposure.exposure_time_s, 1.0 / 125.0);
  EXPECT_DOUBLE_EQ(frame.exposure.aperture_f, 8.0);
  EXPECT_DOUBLE_EQ(frame.exposure.iso, 100.0);
  EXPECT_EQ(frame.timing.sequence, 1u);
  double worst = 0.0;
  for (int v = 0; v < 160; v += 7) {
    for (int u = 0; u < 240; u += 5) {
      for (int c = 0; c < 3; ++c) {
        const double expected = 65535.0 * ExpectedSignal(u, v, c, 1.0 / 125.0, 8.0, 100.0, 0.0);
        worst = std::max(worst, std::abs(frame.image.pixels.at<cv::Vec3w>(v, u)[c] - expected));
      }
    }
  }
  EXPECT_LE(worst, 0.5);  // rounding only: the 16-bit TIFF is lossless
}

// Mean of channel G over the unclipped right half (radiance there is below 1/8 of the peak).
double MeanRightHalfGreen(const StillFrame& frame) {
  const cv::Mat& pixels = frame.image.pixels;
  double sum = 0.0;
  int count = 0;
  for (int v = 0; v < pixels.rows; ++v) {
    for (int u = pixels.cols / 2; u < pixels.cols; ++u) {
      sum += pixels.at<cv::Vec3w>(v, u)[1];
      ++count;
    }
  }
  return sum / count;
}

TEST_F(Gphoto2BackendTest, ShutterApertureIsoAndEvScaleTheSignalPhysically) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  camera->Apply(Settings(1.0 / 500.0, std::nullopt, 8.0, 100.0));
  const double base = MeanRightHalfGreen(camera->Capture());
  ASSERT_GT(base, 100.0);
  camera->Apply(Settings(1.0 / 250.0));
  EXPECT_NEAR(MeanRightHalfGreen(camera->Capture()) / base, 2.0, 2e-3);
  camera->Apply(Settings(1.0 / 500.0, std::nullopt, 5.6));
  EXPECT_NEAR(MeanRightHalfGreen(camera->Capture()) / base, std::pow(8.0 / 5.6, 2.0), 2e-3);
  camera->Apply(Settings(std::nullopt, std::nullopt, 8.0, 400.0));
  EXPECT_NEAR(MeanRightHalfGreen(camera->Capture()) / base, 4.0, 2e-3);
  camera->Apply(Settings(std::nullopt, 1.0, std::nullopt, 100.0));
  EXPECT_NEAR(MeanRightHalfGreen(camera->Capture()) / base, 2.0, 2e-3);
}

TEST_F(Gphoto2BackendTest, CapturesJpegKeptByteForByte) {
  GPhoto2BackendOptions options = Options();
  options.capture_target = "Memory card";
  options.delete_after_download = false;
  GPhoto2Backend backend(options);
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  camera->SetConfigValue("imageformat", "JPEG");
  camera->Apply(Settings(1.0 / 125.0));
  const StillFrame frame = camera->Capture();
  EXPECT_EQ(frame.original_format, "jpeg");
  ASSERT_GE(frame.original_file.size(), 2u);
  EXPECT_EQ(frame.original_file[0], 0xFF);
  EXPECT_EQ(frame.original_file[1], 0xD8);
  // The "memory card" copy the camera wrote is the same file, byte for byte.
  std::ifstream card(folder_ / "DCIM" / "100SIMCM" / "SIM_0001.JPG", std::ios::binary);
  ASSERT_TRUE(card);
  const std::vector<std::uint8_t> on_card((std::istreambuf_iterator<char>(card)), std::istreambuf_iterator<char>());
  EXPECT_EQ(on_card, frame.original_file);
  ASSERT_EQ(frame.image.pixels.type(), CV_8UC3);
  EXPECT_EQ(frame.image.encoding, SampleEncoding::kCameraResponse);
  double worst = 0.0;
  for (int v = 4; v < 156; v += 9) {
    for (int u = 4; u < 236; u += 9) {
      const double s = ExpectedSignal(u, v, 0, 1.0 / 125.0, 8.0, 100.0, 0.0);
      worst = std::max(worst, std::abs(frame.image.pixels.at<cv::Vec3b>(v, u)[0] - 255.0 * std::pow(s, 1.0 / 2.2)));
    }
  }
  EXPECT_LE(worst, 4.0);  // JPEG quantisation at quality 95
}

TEST_F(Gphoto2BackendTest, CapturesRawKeptByteForByteAndDecodesTheMosaic) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  camera->SetConfigValue("imageformat", "RAW");
  camera->Apply(Settings(1.0 / 250.0, std::nullopt, 8.0, 100.0));
  const StillFrame frame = camera->Capture();
  EXPECT_EQ(frame.original_format, "dng");
  EXPECT_TRUE(frame.undecoded_reason.empty()) << frame.undecoded_reason;
  ASSERT_EQ(frame.image.pixels.type(), CV_16UC1);
  EXPECT_EQ(frame.image.layout, ColorLayout::kBayerRggb);
  EXPECT_EQ(frame.image.encoding, SampleEncoding::kSensorLinear);
  EXPECT_EQ(frame.image.black_level, 512);
  EXPECT_EQ(frame.image.white_level, 16383);
  EXPECT_EQ(frame.image.bits_per_sample, 14);
  EXPECT_DOUBLE_EQ(frame.exposure.exposure_time_s, 1.0 / 250.0);
  // Every site of the mosaic holds its channel's analytic signal (simcam_scene.h: RAW).
  int wrong = 0;
  for (int v = 0; v < 160; ++v) {
    for (int u = 0; u < 240; ++u) {
      const int c = (v % 2 == 0) ? (u % 2 == 0 ? 0 : 1) : (u % 2 == 0 ? 1 : 2);
      const double expected = 512 + std::round(15871.0 * ExpectedSignal(u, v, c, 1.0 / 250.0, 8.0, 100.0, 0.0));
      wrong += std::abs(frame.image.pixels.at<std::uint16_t>(v, u) - expected) <= 1.0 ? 0 : 1;  // rounding
    }
  }
  EXPECT_EQ(wrong, 0);
}

TEST_F(Gphoto2BackendTest, RejectsValuesTheCameraDoesNotOfferAndChangesNothing) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  try {
    camera->Apply(Settings(1.0 / 3000.0));
    FAIL() << "1/3000 s is not among the camera's shutter speeds";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kUnsupportedSetting);
    EXPECT_NE(std::string(error.what()).find("1/3200"), std::string::npos) << error.what();
  }
  // A valid shutter speed together with an invalid ISO: neither is applied.
  EXPECT_THROW(camera->Apply(Settings(1.0 / 250.0, std::nullopt, std::nullopt, 150.0)), DeviceError);
  EXPECT_EQ(camera->GetConfigValue("shutterspeed"), "1/60");
  EXPECT_EQ(camera->GetConfigValue("iso"), "100");
  EXPECT_THROW(camera->Apply(Settings(std::nullopt, std::nullopt, std::nullopt, std::nullopt, 3.0)), DeviceError);
  EXPECT_THROW(camera->SetConfigValue("capturetarget", "Cloud"), DeviceError);
  EXPECT_THROW(camera->SetConfigValue("cameramodel", "Other"), DeviceError);  // read-only
  EXPECT_THROW(camera->SetConfigValue("nosuchsetting", "1"), DeviceError);
  camera->SetConfigValue("shutterspeed", "1/250");
  EXPECT_DOUBLE_EQ(camera->Capture().exposure.exposure_time_s, 1.0 / 250.0);
}

TEST_F(Gphoto2BackendTest, BusyIsRetryableAndRetryingCameraRecovers) {
  GPhoto2Backend backend(Options());
  std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  Faults("capture busy 1\n");
  try {
    camera->Capture();
    FAIL() << "expected busy";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kBusy);
    EXPECT_TRUE(error.retryable());
    EXPECT_NE(std::string(error.what()).find("PTP Device Busy"), std::string::npos) << error.what();
  }
  Faults("capture busy 2\n");
  std::vector<DeviceEvent> events;
  RetryingStillCamera retrying(
      std::move(camera), RetryPolicy{}, [&](const DeviceEvent& event) { events.push_back(event); }, [](Nanoseconds) {});
  const StillFrame frame = retrying.Capture();
  EXPECT_FALSE(frame.original_file.empty());
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].error, DeviceErrorKind::kBusy);
}

TEST_F(Gphoto2BackendTest, IoErrorDuringDownloadIsKIo) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  Faults("download io 1\n");
  try {
    camera->Capture();
    FAIL() << "expected an I/O error";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kIo);
  }
  EXPECT_FALSE(camera->Capture().original_file.empty());  // the fault was one-shot
}

TEST_F(Gphoto2BackendTest, DisconnectIsKDisconnected) {
  GPhoto2Backend backend(Options());
  const std::unique_ptr<GPhoto2Camera> camera = backend.Open(Address());
  Faults("any disconnect\n");
  try {
    camera->Capture();
    FAIL() << "expected a disconnect";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kDisconnected);
  }
  EXPECT_THROW(camera->Apply(Settings(1.0 / 250.0)), DeviceError);
}

TEST_F(Gphoto2BackendTest, CameraClaimedByAnotherProcessSaysWhatToDo) {
  GPhoto2Backend backend(Options());
  Faults("init claimed 1\n");
  try {
    backend.Open(Address());
    FAIL() << "expected access denied";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kAccessDenied);
    EXPECT_NE(std::string(error.what()).find("gio mount -s gphoto2"), std::string::npos) << error.what();
  }
  EXPECT_NO_THROW(backend.Open(Address()));
}

TEST_F(Gphoto2BackendTest, UnknownModelOrMissingCameraIsNotFound) {
  GPhoto2Backend backend(Options());
  try {
    backend.Open({"No Such Camera", Address().port});
    FAIL();
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kNotFound);
  }
  try {
    backend.Open({kSimModel, "disk:" + (folder_ / "unplugged").string()});
    FAIL();
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kNotFound);
  }
  DeviceInfo rgbd;
  rgbd.backend = "gphoto2";
  rgbd.id = "x@disk:/";
  rgbd.kind = DeviceKind::kRgbdSensor;
  EXPECT_THROW(backend.OpenRgbdSensor(rgbd), InvalidArgumentError);
  EXPECT_THROW(backend.OpenStillCamera(rgbd), InvalidArgumentError);
}

TEST_F(Gphoto2BackendTest, InvalidOptionsAreRejected) {
  GPhoto2BackendOptions options;
  options.configured = {{kSimModel, "nocolon"}};
  EXPECT_THROW(GPhoto2Backend{options}, InvalidArgumentError);
  options.configured = {{"", "disk:/tmp"}};
  EXPECT_THROW(GPhoto2Backend{options}, InvalidArgumentError);
}

// A real camera on USB, through the installed camera drivers (label "hardware").
TEST(Gphoto2HardwareTest, HardwareAutodetectOpenAndCapture) {
  GPhoto2Backend backend;
  const std::vector<DeviceInfo> devices = backend.Enumerate();
  if (devices.empty()) GTEST_SKIP() << "no camera attached (libgphoto2 autodetected nothing)";
  const std::unique_ptr<StillCamera> camera = backend.OpenStillCamera(devices[0]);
  const StillFrame frame = camera->Capture();
  EXPECT_FALSE(frame.original_file.empty());
  EXPECT_FALSE(frame.original_format.empty());
}

}  // namespace
}  // namespace relume::drivers::gphoto2
