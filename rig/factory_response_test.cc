#include "rig/factory_response.h"

#include <gtest/gtest.h>

#include <cmath>

#include "calibration/hdr_merge.h"
#include "sim/devices/camera_model.h"

namespace relume::rig {
namespace {

sim::SimDeviceSpec RgbdSpec(double iso, double gain_db, sim::ResponseCurve curve) {
  sim::SimDeviceSpec spec;
  spec.id = "kinect";
  spec.kind = drivers::DeviceKind::kRgbdSensor;
  spec.camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(64, 48, 1.0);
  spec.rgbd.color_model.response = curve;
  spec.rgbd.color_exposure.aperture_f = 2.8;
  spec.rgbd.color_exposure.iso = iso;
  spec.rgbd.color_exposure.gain_db = gain_db;
  return spec;
}

// Every code through the factory row, linearised as processing does it (a one-frame merge at
// relative exposure t * ISO / 100), is the radiance the camera model says it means.
void ExpectRowReproducesModel(const sim::SimDeviceSpec& spec, double exposure_time_s) {
  std::string why;
  const auto profile = FactoryColorResponse(spec, &why);
  ASSERT_TRUE(profile) << why;
  ASSERT_TRUE(profile->response);
  CameraImage codes;
  codes.pixels = cv::Mat(1, 256, CV_8UC3);
  for (int z = 0; z < 256; ++z) codes.pixels.at<cv::Vec3b>(0, z) = cv::Vec3b::all(static_cast<std::uint8_t>(z));
  sim::ExposureParams exposure = spec.rgbd.color_exposure;
  exposure.exposure_time_s = exposure_time_s;
  const RadianceImage model =
      sim::RadianceFromCameraImage(codes, spec.camera.intrinsics, exposure, spec.rgbd.color_model);
  const calibration::HdrMergeResult merged = calibration::MergeHdr({codes}, {exposure_time_s * exposure.iso / 100.0},
                                                                   *profile->response, calibration::HdrMergeOptions{});
  int compared = 0;
  for (int z = 3; z < 253; ++z) {  // the merge's margins: codes it reports as bounds
    const float expected = model.pixels.at<cv::Vec3f>(0, z)[1];
    const float got = merged.radiance.pixels.at<cv::Vec3f>(0, z)[1];
    if (!(expected > 0.0f)) continue;  // at or below the black level
    EXPECT_NEAR(got / expected, 1.0, 1e-5) << "code " << z;
    ++compared;
  }
  EXPECT_GT(compared, 200);
  // The saturated code keeps the level below it (the curve is non-decreasing, and no higher).
  EXPECT_EQ(profile->response->inverse[1][255], profile->response->inverse[1][254]);
}

TEST(FactoryResponseTest, ReproducesTheCameraModelInAbsoluteUnits) {
  ExpectRowReproducesModel(RgbdSpec(100.0, 0.0, sim::ResponseCurve::Gamma(2.2)), 1.0 / 60);
  // ISO and gain other than the base: linearisation divides by ISO / 100, the model by its gain.
  ExpectRowReproducesModel(RgbdSpec(400.0, 6.0, sim::ResponseCurve::Filmic(2.2, 1.6)), 1.0 / 250);
}

TEST(FactoryResponseTest, WritesOneRowPerRgbdSensorAndNoneWhereItWouldBeWrong) {
  sim::SimDeviceSpec still = RgbdSpec(100.0, 0.0, sim::ResponseCurve::Gamma(2.2));
  still.id = "dslr";
  still.kind = drivers::DeviceKind::kStillCamera;
  std::string why;
  EXPECT_FALSE(FactoryColorResponse(still, &why));
  EXPECT_NE(why.find("not an RGB-D sensor"), std::string::npos) << why;

  sim::SimDeviceSpec vignetted = RgbdSpec(100.0, 0.0, sim::ResponseCurve::Gamma(2.2));
  vignetted.id = "old-kinect";
  vignetted.rgbd.color_model.vignetting.model = sim::Vignetting::Model::kCos4;
  EXPECT_FALSE(FactoryColorResponse(vignetted, &why));
  EXPECT_NE(why.find("vignetting"), std::string::npos) << why;

  RigConfig rig;
  rig.devices = {still, vignetted, RgbdSpec(100.0, 0.0, sim::ResponseCurve::Gamma(2.2))};
  const std::vector<capture::CalibrationRecord> rows = FactoryResponseRecords(rig, UtcTime(Nanoseconds(0)));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].kind, "response");
  EXPECT_EQ(rows[0].device_id, "sim:kinect");
  const calibration::CalibrationProfile back = calibration::ProfileFromJson(rows[0].json, "row");
  ASSERT_TRUE(back.response);
  EXPECT_EQ(back.response->levels, 256);
  EXPECT_NE(back.camera.find("factory response"), std::string::npos) << back.camera;
}

}  // namespace
}  // namespace relume::rig
