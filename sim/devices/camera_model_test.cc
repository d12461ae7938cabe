#include "sim/devices/camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>

#include "core/error.h"

namespace relume::sim {
namespace {

PinholeIntrinsics SmallCamera(int width = 64, int height = 48) {
  return PinholeIntrinsics::FromHorizontalFov(width, height, 60.0 * std::numbers::pi / 180.0);
}

std::vector<ResponseCurve> AllResponses() {
  std::vector<double> table;  // a measured-looking curve: sqrt-ish with a knee
  for (int i = 0; i <= 16; ++i) table.push_back(std::pow(i / 16.0, 0.6) * (0.98 + 0.02 * i / 16.0));
  return {ResponseCurve::Linear(), ResponseCurve::Gamma(2.2), ResponseCurve::Filmic(2.2, 1.6),
          ResponseCurve::Filmic(1.0, 3.0), ResponseCurve::FromTable(table)};
}

TEST(SimResponseCurveTest, DecodeInvertsEncodeForEveryShape) {
  for (const ResponseCurve& curve : AllResponses()) {
    ASSERT_TRUE(curve.IsValid(nullptr)) << ToString(curve.shape);
    EXPECT_DOUBLE_EQ(curve.Encode(0.0), curve.shape == ResponseCurve::Shape::kTable ? curve.table.front() : 0.0);
    EXPECT_DOUBLE_EQ(curve.Encode(1.0), curve.shape == ResponseCurve::Shape::kTable ? curve.table.back() : 1.0);
    for (int i = 1; i < 1000; ++i) {
      const double x = i / 1000.0;
      ASSERT_NEAR(curve.Decode(curve.Encode(x)), x, 1e-10) << ToString(curve.shape) << " x=" << x;
      ASSERT_GT(curve.Encode(x), curve.Encode(x - 1e-3)) << "not increasing at " << x;
    }
  }
}

TEST(SimResponseCurveTest, FilmicIsSShaped) {
  const ResponseCurve curve = ResponseCurve::Filmic(1.0, 2.0);
  // Slope below 1 near the ends, equal to the contrast in the middle.
  EXPECT_LT(curve.Encode(0.05), 0.05);
  EXPECT_GT(curve.Encode(0.95), 0.95);
  EXPECT_NEAR((curve.Encode(0.501) - curve.Encode(0.499)) / 0.002, 2.0, 1e-4);
}

TEST(SimResponseCurveTest, RejectsNonMonotonicTable) {
  std::string why;
  EXPECT_FALSE(ResponseCurve::FromTable({0.0, 0.5, 0.5, 1.0}).IsValid(&why));
  EXPECT_NE(why.find("strictly increasing"), std::string::npos) << why;
  EXPECT_FALSE(ResponseCurve::FromTable({0.0}).IsValid(&why));
  EXPECT_FALSE(ResponseCurve::FromTable({0.0, 1.2}).IsValid(&why));
}

TEST(SimCameraModelTest, IrradianceFollowsTheFNumberLaw) {
  CameraModelOptions options;
  const PinholeIntrinsics camera = SmallCamera();
  ExposureParams exposure;
  exposure.aperture_f = 4.0;
  const double at_f4 = ElectronsPerRadiance(camera, camera.cx, camera.cy, exposure, options);
  EXPECT_NEAR(at_f4, std::numbers::pi / (4 * 16.0) * exposure.exposure_time_s * options.electrons_per_j_per_sqm,
              1e-9 * at_f4);
  exposure.aperture_f = 8.0;  // two stops: a quarter of the light
  EXPECT_NEAR(ElectronsPerRadiance(camera, camera.cx, camera.cy, exposure, options), at_f4 / 4, 1e-9 * at_f4);
}

TEST(SimCameraModelTest, Cos4VignettingMatchesTheOffAxisAngle) {
  Vignetting vignetting;
  vignetting.model = Vignetting::Model::kCos4;
  const PinholeIntrinsics camera = SmallCamera();
  EXPECT_DOUBLE_EQ(vignetting.Factor(camera, camera.cx, camera.cy), 1.0);
  // The left edge of the image is 30 degrees off axis (60 degree horizontal field of view).
  EXPECT_NEAR(vignetting.Factor(camera, 0.0, camera.cy), std::pow(std::cos(std::numbers::pi / 6), 4), 1e-12);
  Vignetting polynomial;
  polynomial.model = Vignetting::Model::kPolynomial;
  polynomial.k1 = -0.3;
  EXPECT_TRUE(polynomial.IsValid(nullptr));
  EXPECT_NEAR(polynomial.Factor(camera, 0.0, 0.0), 0.7, 1e-12);  // a corner: r = 1
  polynomial.k1 = 0.2;                                           // brightening: not a vignette
  EXPECT_FALSE(polynomial.IsValid(nullptr));
}

// Radiance -> pixel -> radiance over the whole unsaturated range, for every response shape
// and bit depth: the inverse lands within the quantisation cell the true radiance fell in.
TEST(SimCameraModelTest, EncodedRoundTripIsWithinQuantisationForAllResponses) {
  const PinholeIntrinsics camera = SmallCamera(256, 4);
  for (const ResponseCurve& response : AllResponses()) {
    CameraModelOptions options;
    options.response = response;
    options.vignetting.model = Vignetting::Model::kCos4;
    ExposureParams exposure;
    exposure.iso = 200;
    // One row sweeps 0 .. saturation (at that pixel) in 4 * 256 steps across 4 rows.
    RadianceImage radiance = MakeRadianceImage(camera.width, camera.height, RadianceUnit::kWattsPerSqmPerSr);
    for (int y = 0; y < camera.height; ++y) {
      for (int x = 0; x < camera.width; ++x) {
        const double saturation = SaturationRadiance(camera, x + 0.5, y + 0.5, exposure, options);
        const double fraction = (y * camera.width + x) / (1.0 * camera.width * camera.height);
        for (int c = 0; c < 3; ++c) {
          radiance.pixels.at<cv::Vec3f>(y, x)[c] = static_cast<float>(saturation * fraction * (1.0 - 0.001 * c));
        }
      }
    }
    const cv::Mat electrons = ExpectedElectrons(radiance, camera, exposure, options);
    const CameraImage encoded = EncodedFromElectrons(electrons, exposure, options);
    ASSERT_TRUE(encoded.IsValid(nullptr));
    EXPECT_EQ(encoded.encoding, SampleEncoding::kCameraResponse);
    for (int y = 0; y < camera.height; ++y) {
      for (int x = 0; x < camera.width; ++x) {
        for (int c = 0; c < 3; ++c) {
          const double truth = radiance.pixels.at<cv::Vec3f>(y, x)[c];
          const int code = encoded.pixels.at<cv::Vec3b>(y, x)[c];
          if (code == 255) continue;  // the top cell is saturated by definition
          const double back = RadianceFromEncodedValue(code, camera, x + 0.5, y + 0.5, exposure, options);
          const double saturation = SaturationRadiance(camera, x + 0.5, y + 0.5, exposure, options);
          const double lower = response.Decode((code - 0.5) / 255.0) * saturation;
          const double upper = response.Decode((code + 0.5) / 255.0) * saturation;
          ASSERT_GE(truth, lower * (1 - 1e-6) - 1e-9) << ToString(response.shape) << " code " << code;
          ASSERT_LE(truth, upper * (1 + 1e-6) + 1e-9) << ToString(response.shape) << " code " << code;
          ASSERT_LE(std::abs(back - truth), (upper - lower) * (1 + 1e-6) + 1e-9) << ToString(response.shape);
        }
      }
    }
  }
}

TEST(SimCameraModelTest, RawRoundTripIsWithinHalfACountForAllBitDepths) {
  const PinholeIntrinsics camera = SmallCamera(128, 8);
  for (int bits : {8, 12, 14}) {
    for (ColorLayout layout : {ColorLayout::kRgb, ColorLayout::kBayerRggb}) {
      CameraModelOptions options;
      options.raw_bits = bits;
      options.raw_layout = layout;
      options.vignetting.model = Vignetting::Model::kPolynomial;
      options.vignetting.k1 = -0.2;
      ExposureParams exposure;
      exposure.gain_db = 6.0;
      RadianceImage radiance = MakeRadianceImage(camera.width, camera.height, RadianceUnit::kWattsPerSqmPerSr);
      for (int y = 0; y < camera.height; ++y) {
        for (int x = 0; x < camera.width; ++x) {
          const double saturation = SaturationRadiance(camera, x + 0.5, y + 0.5, exposure, options);
          const double fraction = (y * camera.width + x) / (1.0 * camera.width * camera.height);
          radiance.pixels.at<cv::Vec3f>(y, x) = cv::Vec3f::all(static_cast<float>(saturation * fraction));
        }
      }
      const CameraImage raw =
          RawFromElectrons(ExpectedElectrons(radiance, camera, exposure, options), exposure, options);
      std::string why;
      ASSERT_TRUE(raw.IsValid(&why)) << why;
      EXPECT_EQ(raw.layout, layout);
      EXPECT_EQ(raw.bits_per_sample, bits);
      EXPECT_EQ(raw.black_level, std::lround((1 << bits) / 32.0 - 1.0 / 32));
      for (int y = 0; y < camera.height; ++y) {
        for (int x = 0; x < camera.width; ++x) {
          const int channels = layout == ColorLayout::kRgb ? 3 : 1;
          for (int c = 0; c < channels; ++c) {
            const int count = bits == 8 ? raw.pixels.ptr<std::uint8_t>(y)[channels * x + c]
                                        : raw.pixels.ptr<std::uint16_t>(y)[channels * x + c];
            if (count == options.white_level()) continue;  // the top half count reads as saturated
            const double truth = radiance.pixels.at<cv::Vec3f>(y, x)[c];
            const double back = RadianceFromRawCount(count, camera, x + 0.5, y + 0.5, exposure, options);
            const double count_step = SaturationRadiance(camera, x + 0.5, y + 0.5, exposure, options) /
                                      (options.white_level() - options.black_level());
            ASSERT_LE(std::abs(back - truth), 0.5 * count_step * (1 + 1e-5)) << bits << " bits at " << x << "," << y;
          }
        }
      }
    }
  }
}

TEST(SimCameraModelTest, BayerMosaicKeepsTheRightChannel) {
  CameraModelOptions options;
  options.raw_layout = ColorLayout::kBayerRggb;
  ExposureParams exposure;
  const PinholeIntrinsics camera = SmallCamera(4, 4);
  cv::Mat electrons(4, 4, CV_32FC3, cv::Scalar(1000, 2000, 3000));
  const CameraImage raw = RawFromElectrons(electrons, exposure, options);
  const double cpe = options.counts_per_electron();
  const int black = options.black_level();
  EXPECT_EQ(raw.pixels.at<std::uint16_t>(0, 0), std::lround(black + 1000 * cpe));  // R
  EXPECT_EQ(raw.pixels.at<std::uint16_t>(0, 1), std::lround(black + 2000 * cpe));  // G
  EXPECT_EQ(raw.pixels.at<std::uint16_t>(1, 0), std::lround(black + 2000 * cpe));  // G
  EXPECT_EQ(raw.pixels.at<std::uint16_t>(1, 1), std::lround(black + 3000 * cpe));  // B
  (void)camera;
}

TEST(SimCameraModelTest, SaturatedSamplesClipAndInvertToNaN) {
  CameraModelOptions options;
  ExposureParams exposure;
  exposure.iso = 400;  // gain 4: the ADC clips at a quarter of the full well
  cv::Mat electrons(1, 3, CV_32FC3);
  electrons.at<cv::Vec3f>(0, 0) = cv::Vec3f::all(static_cast<float>(options.full_well_e / 4 * 1.01));
  electrons.at<cv::Vec3f>(0, 1) = cv::Vec3f::all(static_cast<float>(options.full_well_e * 3));
  electrons.at<cv::Vec3f>(0, 2) = cv::Vec3f::all(-50.0f);  // read noise below black
  const CameraImage raw = RawFromElectrons(electrons, exposure, options);
  const CameraImage encoded = EncodedFromElectrons(electrons, exposure, options);
  EXPECT_EQ(raw.pixels.at<cv::Vec3w>(0, 0)[0], options.white_level());
  EXPECT_EQ(raw.pixels.at<cv::Vec3w>(0, 1)[0], options.white_level());
  EXPECT_EQ(raw.pixels.at<cv::Vec3w>(0, 2)[0], options.black_level());
  EXPECT_EQ(encoded.pixels.at<cv::Vec3b>(0, 0)[0], 255);
  EXPECT_EQ(encoded.pixels.at<cv::Vec3b>(0, 2)[0], 0);
  const PinholeIntrinsics camera = SmallCamera(3, 1);
  const RadianceImage back = RadianceFromCameraImage(raw, camera, exposure, options);
  EXPECT_TRUE(std::isnan(back.pixels.at<cv::Vec3f>(0, 0)[0]));
  EXPECT_EQ(back.pixels.at<cv::Vec3f>(0, 2)[0], 0.0f);
}

TEST(SimCameraModelTest, NoiseIsSeededAndHasTheModelledVariance) {
  CameraModelOptions options;
  options.read_noise_e = 5.0;
  const double mean_e = 2500.0;
  cv::Mat electrons(200, 200, CV_32FC3, cv::Scalar::all(mean_e));
  const cv::Mat a = AddSensorNoise(electrons, options, 42);
  const cv::Mat b = AddSensorNoise(electrons, options, 42);
  const cv::Mat c = AddSensorNoise(electrons, options, 43);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0.0);
  cv::Scalar mean, stddev;
  cv::meanStdDev(a.reshape(1), mean, stddev);
  const double expected_sigma = std::sqrt(mean_e + 25.0);  // 120000 samples: ~0.2 % error
  EXPECT_NEAR(mean[0], mean_e, 0.01 * expected_sigma * 10);
  EXPECT_NEAR(stddev[0], expected_sigma, 0.01 * expected_sigma);
  // Ground truth untouched.
  EXPECT_EQ(electrons.at<cv::Vec3f>(0, 0)[0], static_cast<float>(mean_e));
  options.shot_noise = false;
  cv::meanStdDev(AddSensorNoise(electrons, options, 1).reshape(1), mean, stddev);
  EXPECT_NEAR(stddev[0], 5.0, 0.05);
}

TEST(SimCameraModelTest, InvalidOptionsAreRejectedWithTheReason) {
  CameraModelOptions options;
  options.raw_bits = 13;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("raw_bits"), std::string::npos);
  options = CameraModelOptions{};
  ExposureParams exposure;
  exposure.exposure_time_s = 0.0;
  const PinholeIntrinsics camera = SmallCamera(4, 4);
  EXPECT_THROW(ExpectedElectrons(MakeRadianceImage(4, 4), camera, exposure, options), InvalidArgumentError);
  exposure = ExposureParams{};
  EXPECT_THROW(ExpectedElectrons(MakeRadianceImage(5, 4), camera, exposure, options), InvalidArgumentError);
}

TEST(SimCameraModelTest, NonFiniteRadianceReadsAsBlack) {
  CameraModelOptions options;
  const PinholeIntrinsics camera = SmallCamera(2, 1);
  RadianceImage radiance = MakeRadianceImage(2, 1);
  radiance.pixels.at<cv::Vec3f>(0, 0) = cv::Vec3f(NAN, INFINITY, -1.0f);
  const cv::Mat electrons = ExpectedElectrons(radiance, camera, ExposureParams{}, options);
  EXPECT_EQ(electrons.at<cv::Vec3f>(0, 0), cv::Vec3f(0, 0, 0));
}

}  // namespace
}  // namespace relume::sim
