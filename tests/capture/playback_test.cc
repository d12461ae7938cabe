// Record a short session with simulated devices, play it back through capture::PlaybackBackend
// into a new session with the recorder, and compare the two frame by frame.
#include "capture/playback.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "capture/recorder.h"
#include "capture/rgbd_geometry.h"
#include "capture/scene_model_record.h"
#include "capture/session_check.h"
#include "drivers/device_error.h"
#include "sim/devices/sim_backend.h"
#include "sim/devices/test_rig.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

drivers::RgbdStreamConfig Qvga() {
  drivers::RgbdStreamConfig c;
  c.depth_width = c.color_width = 320;
  c.depth_height = c.color_height = 240;
  return c;
}

RecorderOptions TwoTriggers() {
  RecorderOptions options;
  options.schedule.kind = ScheduleOptions::Kind::kCount;
  options.schedule.count = 2;
  options.schedule.interval = std::chrono::hours(1);
  // One stop of usable range per frame, so that the scene needs a bracket of several frames.
  options.bracket.saturation_fraction = 0.6;
  options.bracket.min_signal_fraction = 0.3;
  options.bracket.overlap_stops = 0.2;
  return options;
}

SessionInfo Info(const Clock& clock) {
  SessionInfo info;
  info.name = "playback test";
  info.site = Site::FromDegrees(37.97, 23.72, 150);
  info.clock_name = clock.name();
  info.created_utc = clock.NowUtc();
  return info;
}

bool SameDouble(double a, double b) {
  return (std::isnan(a) && std::isnan(b)) || a == b;
}

class PlaybackTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::path(::testing::TempDir()) /
            ("playback_test_" + std::to_string(::getpid()));  // ctest runs cases in parallel
    fs::remove_all(root_);
    // A shutter-list camera (14-bit raw, stored as TIFF) and an RGB-D sensor at 320x240
    // recording 3 frames per trigger, two triggers an hour apart on an event-driven clock.
    sim::testing::TestRig rig;
    sim::SimDeviceSpec still;
    still.id = "dslr";
    still.model = "sim DSLR";
    still.camera = sim::testing::LookingAtWall(160, 120);
    sim::SimDeviceSpec rgbd;
    rgbd.id = "rgbd";
    rgbd.kind = drivers::DeviceKind::kRgbdSensor;
    rgbd.camera = sim::testing::LookingAtWall(640, 480, 58.0);
    auto backend =
        std::make_shared<sim::SimBackend>(std::vector<sim::SimDeviceSpec>{still, rgbd}, rig.truth, rig.clock);
    auto writer = SessionWriter::Create(root_ / "recorded", Info(*rig.clock));
    Recorder recorder(*writer, *rig.clock, TwoTriggers());
    for (const drivers::DeviceInfo& d : backend->Enumerate()) {
      if (d.kind == drivers::DeviceKind::kStillCamera) {
        recorder.AddStillCamera(backend->OpenStillCamera(d), nullptr);
      } else {
        recorder.AddRgbdSensor(backend->OpenRgbdSensor(d), nullptr, Qvga(), 3);
      }
    }
    std::atomic<bool> stop{false};
    ASSERT_EQ(recorder.Run(stop).stop_reason, "the schedule is complete");
  }

  // Replays the recorded session into `name` on a fresh event-driven clock.
  static fs::path Replay(const std::string& name) {
    ManualClock clock(sim::testing::RigStart());
    PlaybackBackend playback(root_ / "recorded");
    auto writer = SessionWriter::Create(root_ / name, Info(clock));
    Recorder recorder(*writer, clock, TwoTriggers());
    for (const drivers::DeviceInfo& d : playback.Enumerate()) {
      if (d.kind == drivers::DeviceKind::kStillCamera) {
        recorder.AddStillCamera(playback.OpenStillCamera(d), nullptr);
      } else {
        auto sensor = playback.OpenRgbdSensor(d);
        const drivers::RgbdStreamConfig config = sensor->SupportedConfigs().front();
        recorder.AddRgbdSensor(std::move(sensor), nullptr, config, 3);
      }
    }
    std::atomic<bool> stop{false};
    const RecorderSummary summary = recorder.Run(stop);
    EXPECT_EQ(summary.status.partial_brackets, 0);
    EXPECT_EQ(summary.status.faults, 0);
    return root_ / name;
  }

  static fs::path root_;
};
fs::path PlaybackTest::root_;

TEST_F(PlaybackTest, ListsTheRecordedDevices) {
  PlaybackBackend playback(root_ / "recorded");
  const auto devices = playback.Enumerate();
  ASSERT_EQ(devices.size(), 2u);
  EXPECT_EQ(devices[0].FullId(), "playback:sim:dslr");
  EXPECT_EQ(devices[0].model, "sim DSLR");
  EXPECT_EQ(devices[1].FullId(), "playback:sim:rgbd");
  EXPECT_EQ(devices[1].details.at("recorded_frames"), "6");
}

TEST_F(PlaybackTest, ReplayIntoANewSessionMatchesFrameByFrame) {
  const fs::path replayed = Replay("replayed");
  const SessionReader original(root_ / "recorded");
  const SessionReader copy(replayed);
  const auto a = original.Frames();
  const auto b = copy.Frames();
  ASSERT_EQ(a.size(), b.size());
  int stills = 0, depths = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE("frame row " + std::to_string(i) + " " + a[i].device_id + " " + a[i].stream);
    EXPECT_EQ(b[i].device_id, "playback:" + a[i].device_id);
    EXPECT_EQ(b[i].stream, a[i].stream);
    EXPECT_EQ(b[i].sha256, a[i].sha256);
    EXPECT_EQ(b[i].file_format, a[i].file_format);
    EXPECT_EQ(b[i].bracket_index, a[i].bracket_index);
    EXPECT_EQ(b[i].bracket_id.has_value(), a[i].bracket_id.has_value());
    EXPECT_TRUE(SameDouble(b[i].exposure.exposure_time_s, a[i].exposure.exposure_time_s));
    EXPECT_TRUE(SameDouble(b[i].exposure.ev_compensation, a[i].exposure.ev_compensation));
    EXPECT_TRUE(SameDouble(b[i].exposure.aperture_f, a[i].exposure.aperture_f));
    EXPECT_TRUE(SameDouble(b[i].exposure.iso, a[i].exposure.iso));
    EXPECT_EQ(b[i].utc, a[i].utc);
    EXPECT_EQ(b[i].monotonic, a[i].monotonic);
    EXPECT_EQ(b[i].device_timestamp, a[i].device_timestamp);
    EXPECT_EQ(b[i].sequence, a[i].sequence);
    EXPECT_EQ(b[i].width, a[i].width);
    EXPECT_EQ(b[i].bits_per_sample, a[i].bits_per_sample);
    stills += a[i].stream == "still" ? 1 : 0;
    depths += a[i].stream == "depth" ? 1 : 0;
  }
  EXPECT_GE(stills, 4);  // two brackets of at least two exposures on the wall-and-sphere scene
  EXPECT_EQ(depths, 6);
  // The same brackets, and the RGB-D stream geometry carried over.
  ASSERT_EQ(copy.Brackets().size(), original.Brackets().size());
  for (std::size_t i = 0; i < original.Brackets().size(); ++i) {
    EXPECT_EQ(copy.Brackets()[i].status, original.Brackets()[i].status);
  }
  std::vector<std::string> geometry_a, geometry_b;
  for (const auto& c : original.Calibrations()) geometry_a.push_back(c.kind + c.json);
  for (const auto& c : copy.Calibrations()) geometry_b.push_back(c.kind + c.json);
  ASSERT_EQ(geometry_a.size(), 1u);
  EXPECT_EQ(geometry_b, geometry_a);
  EXPECT_TRUE(VerifySession(replayed).ok());
}

TEST_F(PlaybackTest, ExposuresAreMatchedWithinTheRecordedBracket) {
  PlaybackBackend playback(root_ / "recorded");
  const auto devices = playback.Enumerate();
  auto camera = playback.OpenStillCamera(devices[0]);
  auto* player = dynamic_cast<PlaybackStillCamera*>(camera.get());
  ASSERT_NE(player, nullptr);
  const drivers::ExposureCapabilities caps = camera->capabilities();
  EXPECT_EQ(caps.control, drivers::ExposureControl::kShutterList);
  ASSERT_FALSE(caps.shutter_speeds_s.empty());

  // A value never recorded is refused by Apply, naming what was recorded.
  drivers::ExposureSettings never;
  never.exposure_time_s = 3.2;
  try {
    camera->Apply(never);
    FAIL() << "3.2 s was accepted";
  } catch (const drivers::DeviceError& e) {
    EXPECT_EQ(e.kind(), drivers::DeviceErrorKind::kUnsupportedSetting);
    EXPECT_NE(std::string(e.what()).find("was never recorded by this device; recorded: "), std::string::npos)
        << e.what();
  }

  // The bracket's frames come back for their exposures, in any order asked.
  const std::optional<RecordedBracket> bracket = player->recorded_brackets()->Next();
  ASSERT_TRUE(bracket.has_value());
  ASSERT_GE(bracket->exposures.size(), 2u);
  const drivers::ExposureSettings last = bracket->exposures.back();
  camera->Apply(last);
  const drivers::StillFrame frame = camera->Capture();
  EXPECT_DOUBLE_EQ(frame.exposure.exposure_time_s, *last.exposure_time_s);
  EXPECT_FALSE(frame.original_file.empty());
  EXPECT_EQ(frame.image.width(), 160);
  // Asking again for an exposure the bracket has already given says so.
  try {
    camera->Capture();
    FAIL() << "the same exposure was played twice";
  } catch (const drivers::DeviceError& e) {
    EXPECT_EQ(e.kind(), drivers::DeviceErrorKind::kUnsupportedSetting);
    EXPECT_NE(std::string(e.what()).find("was not recorded in bracket " + std::to_string(bracket->recorded_id)),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("not yet played: "), std::string::npos) << e.what();
  }
}

TEST_F(PlaybackTest, RgbdFramesArePacedAtTheRecordedIntervalsOnTheClock) {
  auto clock = std::make_shared<ManualClock>(sim::testing::RigStart());
  PlaybackOptions options;
  options.clock = clock;
  PlaybackBackend playback(root_ / "recorded", options);
  auto sensor = playback.OpenRgbdSensor(playback.Enumerate()[1]);
  sensor->Start(sensor->SupportedConfigs().front());
  const MonotonicTime start = clock->NowMonotonic();
  const drivers::RgbdFrame first = sensor->WaitForFrame(std::chrono::seconds(1));
  sensor->WaitForFrame(std::chrono::seconds(1));
  const drivers::RgbdFrame third = sensor->WaitForFrame(std::chrono::seconds(1));
  EXPECT_EQ(clock->NowMonotonic() - start, third.depth_timing.host_monotonic - first.depth_timing.host_monotonic);
  EXPECT_EQ(first.depth_m.cols, 320);
  EXPECT_GT(first.depth_intrinsics.fx, 0.0);
  EXPECT_TRUE(first.registered_to_color);
  // The recording's end is a timeout, as at the end of an OpenNI2 recording.
  for (int i = 0; i < 3; ++i) sensor->WaitForFrame(std::chrono::hours(2));
  EXPECT_THROW(sensor->WaitForFrame(std::chrono::hours(2)), drivers::DeviceError);
  // A device the session does not hold.
  drivers::DeviceInfo absent;
  absent.backend = "playback";
  absent.id = "sim:nope";
  EXPECT_THROW(playback.OpenStillCamera(absent), drivers::DeviceError);
}

// What a replay inherits: the played devices' response and profile rows and the latest scene
// model, renamed; nothing of devices not played; no rgbd_geometry row; no recorded frame ids.
TEST(CarriedCalibrationsTest, OnlyThePlayedDevicesCalibrationsAreCarriedRenamed) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("carried_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  ManualClock clock(sim::testing::RigStart());
  {
    auto writer = SessionWriter::Create(dir, Info(clock));
    const auto model_with = [](const std::vector<std::string>& devices) {
      SceneModel model;
      model.source = "test";
      model.site = Site::FromDegrees(37.97, 23.72, 150);
      for (const std::string& id : devices) {
        SceneModelCamera camera;
        camera.device_id = id;
        camera.camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(320, 240, 1.0);
        model.cameras.push_back(camera);
      }
      return SceneModelToJson(model);
    };
    const UtcTime t = clock.NowUtc();
    writer->AddCalibration({0, t, kSceneModelKind, "", model_with({"sim:dslr"}), {}});  // older: not carried
    writer->AddCalibration({0, t, "response", "sim:dslr", "{\"dslr\": 1}", {4, 5}});
    writer->AddCalibration({0, t, "profile", "sim:rgbd", "{\"rgbd\": 1}", {}});
    writer->AddCalibration({0, t, "response", "sim:other", "{}", {}});
    writer->AddCalibration({0, t, kRgbdGeometryKind, "sim:rgbd", "{}", {}});
    writer->AddCalibration({0, t, kSceneModelKind, "", model_with({"sim:other", "sim:rgbd", "sim:dslr"}), {}});
  }
  const std::vector<CalibrationRecord> carried =
      CarriedCalibrations(SessionReader(dir), {{"sim:dslr", "playback:sim:dslr"}, {"sim:rgbd", "playback:sim:rgbd"}});
  ASSERT_EQ(carried.size(), 3u);
  EXPECT_EQ(carried[0].kind, "response");
  EXPECT_EQ(carried[0].device_id, "playback:sim:dslr");
  EXPECT_EQ(carried[0].json, "{\"dslr\": 1}");
  EXPECT_TRUE(carried[0].source_frame_ids.empty());
  EXPECT_EQ(carried[1].kind, "profile");
  EXPECT_EQ(carried[1].device_id, "playback:sim:rgbd");
  ASSERT_EQ(carried[2].kind, kSceneModelKind);
  const SceneModel model = SceneModelFromJson(carried[2].json, "carried");
  ASSERT_EQ(model.cameras.size(), 2u);
  EXPECT_EQ(model.cameras[0].device_id, "playback:sim:rgbd");
  EXPECT_EQ(model.cameras[1].device_id, "playback:sim:dslr");
  // A device list that plays nothing of this session carries nothing but the scene model's frame.
  const std::vector<CalibrationRecord> none = CarriedCalibrations(SessionReader(dir), {});
  ASSERT_EQ(none.size(), 1u);
  EXPECT_TRUE(SceneModelFromJson(none[0].json, "carried").cameras.empty());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::capture
