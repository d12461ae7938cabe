#include "capture/recorder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <filesystem>

#include "capture/session_check.h"
#include "drivers/device_error.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

// A test camera: a horizontal radiance ramp spanning 14 stops, imaged linearly into 12-bit
// counts at the set exposure time, with scripted failures. Test data for the recorder only.
class RampCamera : public drivers::StillCamera {
 public:
  RampCamera() {
    info_ = {"test", "ramp", drivers::DeviceKind::kStillCamera, "RampCam", "1", "", {}};
    caps_.control = drivers::ExposureControl::kContinuous;
    caps_.min_exposure_time_s = 1e-5;
    caps_.max_exposure_time_s = 10.0;
  }
  std::deque<std::optional<drivers::DeviceErrorKind>> failures;
  int captures = 0;

  const drivers::DeviceInfo& info() const override { return info_; }
  drivers::ExposureCapabilities capabilities() const override { return caps_; }
  void Apply(const drivers::ExposureSettings& settings) override {
    if (settings.exposure_time_s) exposure_s_ = *settings.exposure_time_s;
  }
  drivers::StillFrame Capture() override {
    if (!failures.empty()) {
      const auto failure = failures.front();
      failures.pop_front();
      if (failure) throw drivers::DeviceError(*failure, info_.FullId(), "scripted");
    }
    ++captures;
    drivers::StillFrame frame;
    frame.device_id = info_.FullId();
    if (undecodable_raw) {
      // A raw file the driver could not decode: the bytes only (different for every capture).
      frame.original_file = {0x46, 0x55, 0x4a, 0x49, static_cast<std::uint8_t>(captures)};
      frame.original_format = "raf";
      frame.undecoded_reason = "X-Trans sensors are not supported";
      frame.exposure.exposure_time_s = exposure_s_;
      frame.timing.host_utc = clock->NowUtc();
      frame.timing.host_monotonic = clock->NowMonotonic();
      return frame;
    }
    frame.image.pixels = cv::Mat(8, 64, CV_16UC1);
    for (int x = 0; x < 64; ++x) {
      const double radiance = std::exp2(14.0 * x / 63.0);  // 1 .. 16384
      const double counts = std::min(4095.0, radiance * exposure_s_ * 40.0);
      frame.image.pixels.col(x).setTo(static_cast<int>(counts));
    }
    frame.image.layout = ColorLayout::kMono;
    frame.image.encoding = SampleEncoding::kSensorLinear;
    frame.image.bits_per_sample = 12;
    frame.image.white_level = 4095;
    frame.exposure.exposure_time_s = exposure_s_;
    frame.timing.host_utc = clock->NowUtc();
    frame.timing.host_monotonic = clock->NowMonotonic();
    frame.timing.sequence = static_cast<std::uint64_t>(captures);
    return frame;
  }
  Clock* clock = nullptr;
  bool undecodable_raw = false;

 private:
  drivers::DeviceInfo info_;
  drivers::ExposureCapabilities caps_;
  double exposure_s_ = 1e-3;
};

class RecorderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("recorder_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    SessionInfo info;
    info.name = "recorder test";
    info.site = Site::FromDegrees(37.97, 23.72, 150);
    info.clock_name = clock_.name();
    info.created_utc = clock_.NowUtc();
    writer_ = SessionWriter::Create(dir_, info);
    options_.schedule.kind = ScheduleOptions::Kind::kCount;
    options_.schedule.count = 3;
    options_.schedule.interval = std::chrono::hours(1);
    options_.retry.initial_backoff = std::chrono::milliseconds(10);
  }
  ManualClock clock_{ParseIso8601("2026-06-21T06:00:00Z").utc};
  fs::path dir_;
  std::unique_ptr<SessionWriter> writer_;
  RecorderOptions options_;
};

TEST_F(RecorderTest, ScheduledBracketsCoverTheRampAndAreStored) {
  auto camera = std::make_unique<RampCamera>();
  camera->clock = &clock_;
  Recorder recorder(*writer_, clock_, options_);
  recorder.AddStillCamera(std::move(camera), nullptr);
  std::atomic<bool> stop{false};
  const RecorderSummary summary = recorder.Run(stop);
  EXPECT_EQ(summary.stop_reason, "the schedule is complete");
  EXPECT_EQ(summary.status.brackets, 3);
  EXPECT_EQ(summary.status.partial_brackets, 0);
  writer_.reset();
  const SessionReader reader(dir_);
  const auto brackets = reader.Brackets();
  ASSERT_EQ(brackets.size(), 3u);
  for (const auto& b : brackets) EXPECT_EQ(b.status, "complete");
  // Two hours apart on the clock; sun elevation recorded per frame and rising in the morning.
  const auto frames = reader.Frames();
  ASSERT_GE(frames.size(), 6u);
  EXPECT_EQ(brackets[2].started_utc - brackets[0].started_utc, std::chrono::hours(2));
  EXPECT_LT(frames.front().sun_elevation_deg, frames.back().sun_elevation_deg);
  EXPECT_TRUE(VerifySession(dir_).ok());
  // The 14-stop ramp needs several exposures; every ramp position is usable in some frame.
  std::vector<bool> usable(64, false);
  for (const auto& f : frames) {
    if (f.bracket_id != brackets[0].id) continue;
    const CameraImage image = reader.LoadImage(f);
    for (int x = 0; x < 64; ++x) {
      const int v = image.pixels.at<std::uint16_t>(0, x);
      usable[static_cast<std::size_t>(x)] =
          usable[static_cast<std::size_t>(x)] || (v >= 0.04 * 4095 && v <= 0.9 * 4095 + 1);
    }
  }
  for (int x = 1; x < 64; ++x) EXPECT_TRUE(usable[static_cast<std::size_t>(x)]) << "ramp position " << x;
}

TEST_F(RecorderTest, BusyCamerasAreRetriedAndRecordedAsEvents) {
  auto camera = std::make_unique<RampCamera>();
  camera->clock = &clock_;
  camera->failures = {std::nullopt, drivers::DeviceErrorKind::kBusy, drivers::DeviceErrorKind::kBusy};
  options_.schedule.count = 1;
  Recorder recorder(*writer_, clock_, options_);
  recorder.AddStillCamera(std::move(camera), nullptr);
  std::atomic<bool> stop{false};
  const RecorderSummary summary = recorder.Run(stop);
  EXPECT_EQ(summary.status.partial_brackets, 0);
  EXPECT_EQ(summary.status.faults, 2);
  writer_.reset();
  int retries = 0;
  for (const auto& e : SessionReader(dir_).Events()) retries += e.type == "retry" ? 1 : 0;
  EXPECT_EQ(retries, 2);
}

TEST_F(RecorderTest, AnUnrecoverableCameraGivesAPartialBracketNotACrash) {
  auto camera = std::make_unique<RampCamera>();
  camera->clock = &clock_;
  // Metering works, then the camera disconnects for good and cannot be reopened.
  camera->failures = {std::nullopt, std::nullopt, drivers::DeviceErrorKind::kDisconnected};
  options_.schedule.count = 1;
  options_.retry.max_attempts = 2;
  Recorder recorder(*writer_, clock_, options_);
  recorder.AddStillCamera(std::move(camera), []() -> std::unique_ptr<drivers::StillCamera> {
    throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, "test:ramp", "unplugged");
  });
  std::atomic<bool> stop{false};
  const RecorderSummary summary = recorder.Run(stop);
  EXPECT_EQ(summary.status.brackets, 1);
  EXPECT_EQ(summary.status.partial_brackets, 1);
  writer_.reset();
  const SessionReader reader(dir_);
  ASSERT_EQ(reader.Brackets().size(), 1u);
  EXPECT_EQ(reader.Brackets()[0].status, "partial");
  EXPECT_NE(reader.Brackets()[0].reason.find("reconnect failed"), std::string::npos) << reader.Brackets()[0].reason;
  EXPECT_EQ(reader.Frames().size(), 1u);  // the frame stored before the disconnect is kept
  EXPECT_TRUE(VerifySession(dir_).ok());
}

TEST_F(RecorderTest, RawFilesRelumeCannotDecodeAreRecordedWithAnUnmeteredBracket) {
  auto camera = std::make_unique<RampCamera>();
  camera->clock = &clock_;
  camera->undecodable_raw = true;
  RampCamera* camera_ptr = camera.get();
  options_.schedule.count = 1;
  Recorder recorder(*writer_, clock_, options_);
  recorder.AddStillCamera(std::move(camera), nullptr);
  std::atomic<bool> stop{false};
  const RecorderSummary summary = recorder.Run(stop);
  EXPECT_EQ(summary.status.brackets, 1);
  EXPECT_EQ(summary.status.partial_brackets, 0);
  writer_.reset();
  const SessionReader reader(dir_);
  ASSERT_EQ(reader.Brackets().size(), 1u);
  EXPECT_EQ(reader.Brackets()[0].status, "complete");
  // Every capture after the metering frame is stored, byte for byte, without pixels.
  const std::vector<FrameRecord> frames = reader.Frames();
  ASSERT_EQ(static_cast<int>(frames.size()), camera_ptr->captures - 1);
  EXPECT_GE(frames.size(), 3u) << "an unmetered bracket spans +-4 stops";
  double shortest = 1e9, longest = 0;
  for (const FrameRecord& f : frames) {
    EXPECT_EQ(f.file_format, "raf");
    EXPECT_EQ(f.width, 0);
    shortest = std::min(shortest, f.exposure.exposure_time_s);
    longest = std::max(longest, f.exposure.exposure_time_s);
  }
  EXPECT_GE(std::log2(longest / shortest), 6.0);
  bool said = false;
  for (const EventRecord& e : reader.Events()) said = said || e.message.find("cannot be metered") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_TRUE(VerifySession(dir_).ok()) << VerifySession(dir_).Summary();
}

TEST_F(RecorderTest, StopRequestEndsCleanly) {
  auto camera = std::make_unique<RampCamera>();
  camera->clock = &clock_;
  Recorder recorder(*writer_, clock_, options_);
  recorder.AddStillCamera(std::move(camera), nullptr);
  std::atomic<bool> stop{true};
  const RecorderSummary summary = recorder.Run(stop);
  EXPECT_TRUE(summary.stopped_by_user);
  EXPECT_EQ(summary.status.brackets, 0);
}

}  // namespace
}  // namespace relume::capture
