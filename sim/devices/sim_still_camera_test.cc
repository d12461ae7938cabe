#include "sim/devices/sim_still_camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/device_error.h"
#include "sim/devices/test_rig.h"

namespace relume::sim {
namespace {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::ExposureControl;
using drivers::ExposureSettings;
using testing::LookingAtWall;
using testing::TestRig;

drivers::DeviceInfo Info(const std::string& id = "cam0") {
  drivers::DeviceInfo info;
  info.backend = "sim";
  info.id = id;
  info.model = "Sim DSLR";
  return info;
}

SimStillCameraOptions NoiseFree(ExposureControl control) {
  SimStillCameraOptions options = SimStillCameraOptions::ForControl(control);
  options.add_noise = false;
  return options;
}

ExposureSettings Time(double s) {
  ExposureSettings settings;
  settings.exposure_time_s = s;
  return settings;
}
ExposureSettings Ev(double ev) {
  ExposureSettings settings;
  settings.ev_compensation = ev;
  return settings;
}
ExposureSettings Aperture(double f) {
  ExposureSettings settings;
  settings.aperture_f = f;
  return settings;
}
ExposureSettings Iso(double iso) {
  ExposureSettings settings;
  settings.iso = iso;
  return settings;
}
ExposureSettings Gain(double db) {
  ExposureSettings settings;
  settings.gain_db = db;
  return settings;
}

DeviceErrorKind KindOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const DeviceError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "expected a DeviceError";
  return DeviceErrorKind::kIo;
}

TEST(SimStillCameraTest, RawFrameInvertsToTheTruthAtTheClocksTime) {
  testing::AnalyticScene scene = testing::WallAndSphereScene();
  scene.spheres[0].velocity_m_per_s = Eigen::Vector3d(0.0, 0.5, 0.0);  // it moves: time matters
  TestRig rig(scene);
  const PinholeCamera camera = LookingAtWall(64, 48);
  SimStillCameraOptions options = NoiseFree(ExposureControl::kShutterList);
  SimStillCamera sim(Info(), options, camera, rig.truth, rig.clock);
  rig.clock->Advance(std::chrono::seconds(2));
  const UtcTime shot_time = rig.clock->NowUtc();
  const drivers::StillFrame frame = sim.Capture();
  ASSERT_EQ(frame.image.encoding, SampleEncoding::kSensorLinear);
  const ExposureParams exposure{frame.exposure.exposure_time_s, frame.exposure.aperture_f, frame.exposure.iso, 0.0};
  const RadianceImage back = RadianceFromCameraImage(frame.image, camera.intrinsics, exposure, options.model);
  const GroundTruth at_shot = rig.truth->Render(camera, shot_time);
  const GroundTruth at_start = rig.truth->Render(camera, testing::RigStart());
  double worst = 0.0, moved = 0.0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      const double step = SaturationRadiance(camera.intrinsics, x + 0.5, y + 0.5, exposure, options.model) /
                          (options.model.white_level() - options.model.black_level());
      for (int c = 0; c < 3; ++c) {
        const double truth = at_shot.radiance.pixels.at<cv::Vec3f>(y, x)[c];
        const double error = std::abs(back.pixels.at<cv::Vec3f>(y, x)[c] - truth) / step;
        worst = std::max(worst, error);
        moved = std::max(moved, std::abs(at_start.radiance.pixels.at<cv::Vec3f>(y, x)[c] - truth));
      }
    }
  }
  EXPECT_LE(worst, 0.5 + 1e-3) << "in counts";
  EXPECT_GT(moved, 1.0) << "the sphere should have moved between the two times";
}

TEST(SimStillCameraTest, OriginalFileDecodesToTheSamePixels) {
  TestRig rig;
  for (auto output : {SimStillCameraOptions::Output::kRaw, SimStillCameraOptions::Output::kEncoded}) {
    for (ColorLayout layout : {ColorLayout::kRgb, ColorLayout::kBayerRggb}) {
      SimStillCameraOptions options = SimStillCameraOptions::ForControl(ExposureControl::kShutterList);
      options.output = output;
      options.model.raw_layout = layout;
      SimStillCamera sim(Info(), options, LookingAtWall(40, 30), rig.truth, rig.clock);
      const drivers::StillFrame frame = sim.Capture();
      EXPECT_EQ(frame.original_format, output == SimStillCameraOptions::Output::kRaw ? "tiff" : "png");
      cv::Mat decoded = cv::imdecode(frame.original_file, cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(decoded.empty());
      if (decoded.channels() == 3) {
        cv::Mat rgb(decoded.size(), decoded.type());
        const int from_to[] = {0, 2, 1, 1, 2, 0};
        cv::mixChannels(&decoded, 1, &rgb, 1, from_to, 3);
        decoded = rgb;
      }
      ASSERT_EQ(decoded.type(), frame.image.pixels.type());
      EXPECT_EQ(cv::norm(decoded, frame.image.pixels, cv::NORM_INF), 0.0);
    }
  }
}

TEST(SimStillCameraTest, TimingComesFromTheClockAndTheDeviceClock) {
  TestRig rig;
  SimStillCameraOptions options = NoiseFree(ExposureControl::kShutterList);
  options.readout_time_s = 0.25;
  options.device_clock.offset_s = 100.0;
  options.device_clock.drift_ppm = 50.0;
  options.sensor_temperature_c = 41.5;
  SimStillCamera sim(Info(), options, LookingAtWall(16, 12), rig.truth, rig.clock);
  ExposureSettings settings;
  settings.exposure_time_s = 0.5;
  sim.Apply(settings);
  rig.clock->Advance(std::chrono::seconds(10));
  const drivers::StillFrame first = sim.Capture();
  EXPECT_EQ(first.timing.host_utc, testing::RigStart() + std::chrono::milliseconds(10750));
  EXPECT_EQ(first.timing.host_monotonic.time_since_epoch(), std::chrono::milliseconds(10750));
  ASSERT_TRUE(first.timing.device_timestamp);
  // Exposure started at host 10 s: device = 100 + 10 * (1 + 50e-6) s.
  EXPECT_NEAR(std::chrono::duration<double>(*first.timing.device_timestamp).count(), 110.0005, 1e-9);
  EXPECT_EQ(first.timing.sequence, 1u);
  EXPECT_EQ(sim.Capture().timing.sequence, 2u);
  EXPECT_EQ(first.sensor_temperature_c, 41.5);
  EXPECT_EQ(first.device_id, "sim:cam0");
  EXPECT_DOUBLE_EQ(first.exposure.exposure_time_s, 0.5);
  EXPECT_TRUE(std::isnan(first.exposure.gain_db));  // a DSLR has no gain setting
}

TEST(SimStillCameraTest, ApplyRejectsValuesNotOfferedAndChangesNothing) {
  TestRig rig;
  SimStillCamera dslr(Info(), NoiseFree(ExposureControl::kShutterList), LookingAtWall(8, 6), rig.truth, rig.clock);
  const ExposureParams before = dslr.exposure();
  ExposureSettings bad;
  bad.aperture_f = 11.0;             // offered
  bad.exposure_time_s = 1.0 / 3000;  // not a marked shutter speed
  EXPECT_EQ(KindOf([&] { dslr.Apply(bad); }), DeviceErrorKind::kUnsupportedSetting);
  EXPECT_EQ(dslr.exposure().aperture_f, before.aperture_f);
  EXPECT_EQ(dslr.exposure().exposure_time_s, before.exposure_time_s);
  ExposureSettings good;
  good.exposure_time_s = 1.0 / 4000;
  good.aperture_f = 5.6;
  good.iso = 800;
  dslr.Apply(good);
  EXPECT_EQ(dslr.exposure().exposure_time_s, 1.0 / 4000);
  EXPECT_EQ(dslr.exposure().iso, 800);
  for (auto setting : std::vector<ExposureSettings>{Time(31.0), Ev(1.0), Aperture(1.4), Iso(150), Gain(6.0)}) {
    EXPECT_EQ(KindOf([&] { dslr.Apply(setting); }), DeviceErrorKind::kUnsupportedSetting);
  }

  SimStillCamera machine(Info("mv0"), NoiseFree(ExposureControl::kContinuous), LookingAtWall(8, 6), rig.truth,
                         rig.clock);
  ExposureSettings machine_settings = Time(1.234e-3);
  machine_settings.gain_db = 12.5;
  machine.Apply(machine_settings);
  EXPECT_EQ(machine.exposure().exposure_time_s, 1.234e-3);
  for (auto setting : std::vector<ExposureSettings>{Time(5e-6), Time(11.0), Gain(30.0), Iso(200)}) {
    EXPECT_EQ(KindOf([&] { machine.Apply(setting); }), DeviceErrorKind::kUnsupportedSetting);
  }

  SimStillCamera ev(Info("ev0"), NoiseFree(ExposureControl::kEvOnly), LookingAtWall(8, 6), rig.truth, rig.clock);
  ev.Apply(Ev(-2.0 / 3));
  EXPECT_DOUBLE_EQ(ev.ev_compensation(), -2.0 / 3);
  for (auto setting : std::vector<ExposureSettings>{Time(0.01), Ev(0.5), Ev(5.4)}) {
    EXPECT_EQ(KindOf([&] { ev.Apply(setting); }), DeviceErrorKind::kUnsupportedSetting);
  }
  EXPECT_DOUBLE_EQ(ev.ev_compensation(), -2.0 / 3);
}

TEST(SimStillCameraTest, DslrShutterListCoversQuarterMillisecondToThirtySecondsInThirdStops) {
  const drivers::ExposureCapabilities caps = DslrCapabilities();
  ASSERT_EQ(caps.shutter_speeds_s.front(), 1.0 / 4000);
  ASSERT_EQ(caps.shutter_speeds_s.back(), 30.0);
  for (std::size_t i = 1; i < caps.shutter_speeds_s.size(); ++i) {
    const double stops = std::log2(caps.shutter_speeds_s[i] / caps.shutter_speeds_s[i - 1]);
    EXPECT_NEAR(stops, 1.0 / 3, 0.15) << "between " << caps.shutter_speeds_s[i - 1] << " and "
                                      << caps.shutter_speeds_s[i];
  }
  const drivers::ExposureCapabilities ev = EvOnlyCapabilities();
  EXPECT_EQ(ev.ev_steps.size(), 31u);
  EXPECT_DOUBLE_EQ(ev.ev_steps.front(), -5.0);
  EXPECT_DOUBLE_EQ(ev.ev_steps.back(), 5.0);
}

// A uniform grey wall: the metered exposure puts it at mid-grey, and each EV doubles it.
TEST(SimStillCameraTest, EvOnlyMetersToMidGreyAndReportsOnlyTheRatio) {
  testing::AnalyticScene scene;
  testing::AnalyticPlane wall;
  wall.point_in_world = Eigen::Vector3d(3, 0, 0);
  wall.normal_in_world = -Eigen::Vector3d::UnitX();
  wall.albedo = Eigen::Vector3d::Constant(0.4);
  scene.planes.push_back(wall);
  TestRig rig(scene);
  SimStillCameraOptions options = NoiseFree(ExposureControl::kEvOnly);
  options.model.response = ResponseCurve::Linear();
  SimStillCamera sim(Info(), options, LookingAtWall(32, 24, 20.0), rig.truth, rig.clock);
  auto centre_fraction = [&](const drivers::StillFrame& frame) {
    const int count = frame.image.pixels.at<cv::Vec3w>(12, 16)[1];
    return (count - frame.image.black_level) / static_cast<double>(frame.image.white_level - frame.image.black_level);
  };
  const drivers::StillFrame base = sim.Capture();
  EXPECT_TRUE(std::isnan(base.exposure.exposure_time_s));
  EXPECT_EQ(base.exposure.ev_compensation, 0.0);
  // Uniform wall, narrow lens without vignetting: every pixel is the median.
  EXPECT_NEAR(centre_fraction(base), 0.18, 2e-4);
  sim.Apply(Ev(1.0));
  const drivers::StillFrame brighter = sim.Capture();
  EXPECT_EQ(brighter.exposure.ev_compensation, 1.0);
  EXPECT_NEAR(centre_fraction(brighter), 0.36, 2e-4);
  sim.Apply(Ev(-5.0));
  EXPECT_NEAR(centre_fraction(sim.Capture()), 0.18 / 32, 2e-4);
}

TEST(SimStillCameraTest, BlackSceneMetersToTheLongestExposure) {
  testing::AnalyticScene dark;
  dark.sky_radiance.setZero();
  const MeteringResult result =
      MeterExposure(testing::AnalyticTruth(dark).Render(LookingAtWall(8, 6), testing::RigStart()).radiance,
                    LookingAtWall(8, 6).intrinsics, ExposureParams{}, CameraModelOptions{}, MeteringOptions{});
  EXPECT_EQ(result.exposure_time_s, MeteringOptions{}.max_exposure_time_s);
  EXPECT_TRUE(result.clamped);
}

TEST(SimStillCameraTest, NoiseIsReproducibleFrameByFrame) {
  TestRig rig;
  SimStillCameraOptions options = SimStillCameraOptions::ForControl(ExposureControl::kShutterList);
  std::vector<cv::Mat> first_run;
  for (int run = 0; run < 2; ++run) {
    TestRig fresh;
    SimStillCamera sim(Info(), options, LookingAtWall(16, 12), fresh.truth, fresh.clock);
    const cv::Mat a = sim.Capture().image.pixels, b = sim.Capture().image.pixels;
    EXPECT_GT(cv::norm(a, b, cv::NORM_INF), 0.0) << "frames should get different noise";
    if (run == 0) {
      first_run = {a, b};
    } else {
      EXPECT_EQ(cv::norm(a, first_run[0], cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(b, first_run[1], cv::NORM_INF), 0.0);
    }
  }
}

TEST(SimStillCameraTest, SecondHandleIsDeniedUntilTheFirstCloses) {
  TestRig rig;
  auto link = std::make_shared<DeviceLink>(FaultPlan{}, rig.clock);
  auto first = std::make_unique<SimStillCamera>(Info(), NoiseFree(ExposureControl::kShutterList), LookingAtWall(8, 6),
                                                rig.truth, rig.clock, link);
  EXPECT_EQ(KindOf([&] {
              SimStillCamera second(Info(), NoiseFree(ExposureControl::kShutterList), LookingAtWall(8, 6), rig.truth,
                                    rig.clock, link);
            }),
            DeviceErrorKind::kAccessDenied);
  first.reset();
  SimStillCamera third(Info(), NoiseFree(ExposureControl::kShutterList), LookingAtWall(8, 6), rig.truth, rig.clock,
                       link);
  EXPECT_EQ(third.Capture().timing.sequence, 1u);
}

}  // namespace
}  // namespace relume::sim
