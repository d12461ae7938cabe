// Numerical stress across stages. Each case is an input the design card names as dangerous
// (near-zero denominators, normals covering a small part of the sphere, saturated and black
// pixels, NaN/Inf and holes in depth, the sun at the horizon and below it, polar sites, far
// dates), drawn at random with a fixed seed, and has a defined outcome: a correct result, a
// result flagged as low-confidence with the reason, or a clear error — never a silent NaN.
// Every test counts its cases; the last one prints the total.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <random>

#include "calibration/hdr_merge.h"
#include "calibration/response.h"
#include "core/error.h"
#include "core/pinhole.h"
#include "core/site.h"
#include "core/sun/sun_position.h"
#include "processing/normals.h"
#include "processing/relight.h"
#include "processing/sh.h"
#include "processing/sh_fit.h"

namespace relume {
namespace {

// Each test counts its cases and reports them (ctest runs every test in its own process).
class StressTest : public ::testing::Test {
 protected:
  void TearDown() override {
    RecordProperty("cases", g_cases);
    std::printf("stress %s: %d cases, no NaN or Inf where a value was promised\n",
                ::testing::UnitTest::GetInstance()->current_test_info()->name(), g_cases);
  }
  int g_cases = 0;
};

bool AllFinite(const cv::Mat& m) {
  cv::Mat f;
  m.convertTo(f, CV_64F);
  return cv::checkRange(f);
}

// Sun position: every latitude including the poles, heights from -400 m to 8000 m, years
// 1000-3000, instants at any time of day (so the sun is often at or below the horizon).
TEST_F(StressTest, SunPositionIsFiniteEverywhere) {
  std::mt19937_64 rng(20261122);
  std::uniform_real_distribution<double> lat(-90.0, 90.0), lon(-180.0, 180.0), height(-400.0, 8000.0);
  std::uniform_real_distribution<double> seconds(-30.0 * 365.25 * 86400 * 32, 30.0 * 365.25 * 86400 * 10);
  int below = 0;
  for (int i = 0; i < 3000; ++i, ++g_cases) {
    const double latitude = i % 50 == 0 ? (i % 100 == 0 ? 90.0 : -90.0) : lat(rng);
    const Site site = Site::FromDegrees(latitude, lon(rng), height(rng));
    const UtcTime t{std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(seconds(rng)))};
    const SunPosition p = ComputeSunPosition(site, t);
    ASSERT_TRUE(std::isfinite(p.elevation_rad) && std::isfinite(p.azimuth_rad) && std::isfinite(p.zenith_rad))
        << "lat " << latitude << " t " << FormatIso8601(t);
    EXPECT_LE(std::fabs(p.elevation_rad), M_PI / 2 + 1e-9);
    EXPECT_GE(p.azimuth_rad, 0.0);
    EXPECT_LT(p.azimuth_rad, 2 * M_PI);
    below += p.elevation_rad < 0.0;
  }
  EXPECT_GT(below, 1000) << "the sun below the horizon is part of the test";
}

// HDR merge: random brackets of 1-9 frames, exposure ratios up to 1e6, duplicated exposures,
// scenes with black and saturated regions. Outcome: a finite radiance everywhere; pixels
// saturated (or black) in every frame flagged as lower (upper) bounds.
TEST_F(StressTest, HdrMergeIsFiniteAndFlagsClippedPixels) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> frame_count(1, 9);
  std::uniform_real_distribution<double> log_t(-6.0, 0.0), u(0.0, 1.0);
  const calibration::CameraResponse response = calibration::CameraResponse::Linear(3, 256, 0, 255);
  for (int trial = 0; trial < 60; ++trial, ++g_cases) {
    const int n = frame_count(rng);
    const int w = 40, h = 30;
    cv::Mat radiance(h, w, CV_64FC3);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const double kind = u(rng);
        const double value = kind < 0.1 ? 0.0 : (kind > 0.9 ? 1e9 : std::pow(10.0, 8.0 * u(rng) - 2.0));
        radiance.at<cv::Vec3d>(y, x) = cv::Vec3d(value, value * u(rng), value);
      }
    }
    std::vector<CameraImage> frames;
    std::vector<double> times;
    for (int j = 0; j < n; ++j) {
      const double t = j > 0 && u(rng) < 0.2 ? times.back() : std::pow(10.0, log_t(rng));
      times.push_back(t);
      CameraImage image;
      image.pixels = cv::Mat(h, w, CV_8UC3);
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          for (int c = 0; c < 3; ++c) {
            image.pixels.at<cv::Vec3b>(y, x)[c] =
                static_cast<std::uint8_t>(std::clamp(radiance.at<cv::Vec3d>(y, x)[c] * t, 0.0, 255.0));
          }
        }
      }
      frames.push_back(image);
    }
    const calibration::HdrMergeResult merged = calibration::MergeHdr(frames, times, response);
    ASSERT_TRUE(AllFinite(merged.radiance.pixels)) << "trial " << trial << ": " << merged.summary.BriefReport();
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        bool saturated_everywhere = true;
        for (const CameraImage& f : frames) saturated_everywhere &= f.pixels.at<cv::Vec3b>(y, x)[0] >= 254;
        if (saturated_everywhere) {
          EXPECT_EQ(merged.status.at<std::uint8_t>(y, x) & calibration::kHdrSaturatedLowerBound,
                    calibration::kHdrSaturatedLowerBound);
        }
      }
    }
  }
}

// Response recovery from brackets that carry no information (all saturated, all black, one
// code): usable = false with a reason, and a curve that is still finite.
TEST_F(StressTest, ResponseRecoveryFromUselessBracketsSaysSo) {
  for (const int code : {0, 255, 128}) {
    ++g_cases;
    std::vector<CameraImage> frames(3);
    for (CameraImage& f : frames) f.pixels = cv::Mat(20, 20, CV_8UC3, cv::Scalar::all(code));
    const calibration::ResponseResult r = calibration::RecoverResponse(frames, {0.01, 0.1, 1.0});
    EXPECT_FALSE(r.summary.usable) << "code " << code;
    EXPECT_FALSE(r.summary.reason.empty());
    EXPECT_NE(r.summary.BriefReport().find("NOT usable"), std::string::npos);
    for (const auto& channel : r.response.inverse) {
      for (const double v : channel) ASSERT_TRUE(std::isfinite(v));
    }
  }
}

// The least-squares scale between images (Loscos eq. 3) with zero, NaN and empty inputs.
TEST_F(StressTest, ScaleFitWithDegenerateInputsIsFlagged) {
  const cv::Mat zero = cv::Mat::zeros(10, 10, CV_32FC3);
  cv::Mat ones(10, 10, CV_32FC3, cv::Scalar::all(1.0));
  cv::Mat nan(10, 10, CV_32FC3, cv::Scalar::all(std::nan("")));
  const cv::Mat none = cv::Mat::zeros(10, 10, CV_8UC1);
  for (const auto& [values, reference, mask] : std::vector<std::tuple<cv::Mat, cv::Mat, cv::Mat>>{
           {zero, ones, cv::Mat()}, {ones, zero, cv::Mat()}, {nan, ones, cv::Mat()}, {ones, ones, none}}) {
    ++g_cases;
    const calibration::ScaleFit fit = calibration::FitScaleFactor(values, reference, mask);
    EXPECT_TRUE(std::isfinite(fit.scale));
    EXPECT_TRUE(std::isfinite(fit.relative_rms));
    EXPECT_FALSE(fit.usable) << "degenerate input must not give a usable scale";
  }
}

// SH fits where the normals cover a small part of the sphere (down to one direction), with
// zero radiance, or no observations: finite coefficients, order reduced or usable = false.
TEST_F(StressTest, ShFitOnNarrowNormalsReducesOrderOrSaysSo) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const double spread : {0.0, 1e-6, 1e-3, 0.05, 0.3, 1.0}) {
    for (const bool dark : {false, true}) {
      ++g_cases;
      std::vector<processing::ShObservation> obs;
      for (int i = 0; i < 500; ++i) {
        processing::ShObservation o;
        o.normal = (Eigen::Vector3d(0, 0, -1) + spread * Eigen::Vector3d(g(rng), g(rng), g(rng))).normalized();
        o.radiance = dark ? Eigen::Vector3d::Zero() : Eigen::Vector3d::Constant(0.5 + 0.1 * o.normal.x());
        obs.push_back(o);
      }
      const processing::ShFitResult fit = processing::FitShKnownAlbedo(obs);
      ASSERT_TRUE(fit.light.allFinite()) << "spread " << spread;
      if (spread < 0.05) {
        EXPECT_TRUE(!fit.summary.usable || fit.summary.order_reduced || fit.summary.order_used < 2)
            << "spread " << spread << ": order 2 cannot be supported";
      }
      EXPECT_TRUE(std::isfinite(fit.summary.condition_number) || !fit.summary.usable);
    }
  }
  ++g_cases;
  const processing::ShFitResult empty = processing::FitShKnownAlbedo({});
  EXPECT_FALSE(empty.summary.usable);
  EXPECT_TRUE(empty.light.allFinite());
}

// Relighting with a near-zero or zero source irradiance: guarded, never divided; relit
// pixels finite.
TEST_F(StressTest, RelightNeverDividesByNearZeroIrradiance) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const double scale : {0.0, 1e-30, 1e-12, 1.0}) {
    ++g_cases;
    RadianceImage src = MakeRadianceImage(32, 24);
    cv::Mat normals(24, 32, CV_32FC3);
    for (int y = 0; y < 24; ++y) {
      for (int x = 0; x < 32; ++x) {
        src.pixels.at<cv::Vec3f>(y, x) = cv::Vec3f(0.5f, 0.4f, 0.3f);
        Eigen::Vector3d n(u(rng), u(rng), -1.0);
        n.normalize();
        normals.at<cv::Vec3f>(y, x) =
            cv::Vec3f(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
      }
    }
    processing::ShRgb src_light = processing::ShRgb::Zero();
    src_light.row(0).setConstant(scale);
    src_light(3, 0) = -0.9 * scale;  // makes some normals' irradiance ~0 or negative
    processing::ShRgb dst_light = processing::ShRgb::Zero();
    dst_light.row(0).setConstant(1.0);
    const processing::RelightResult r = processing::RelightSh(src, normals, cv::Mat(), src_light, dst_light);
    for (int y = 0; y < 24; ++y) {
      for (int x = 0; x < 32; ++x) {
        if (r.valid.at<std::uint8_t>(y, x) == 0) continue;
        const cv::Vec3f v = r.relit.pixels.at<cv::Vec3f>(y, x);
        ASSERT_TRUE(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2])) << "scale " << scale;
      }
    }
    if (scale == 0.0) {
      EXPECT_EQ(r.summary.relit_pixel_count, 0) << "nothing can be relit from no light";
    }
  }
}

// Normals from depth with NaN, +-Inf, zero (holes), negative values and spikes: every valid
// normal is a finite unit vector; invalid pixels are flagged, not guessed.
TEST_F(StressTest, NormalsFromBrokenDepthAreFiniteOrFlagged) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const PinholeIntrinsics intrinsics = PinholeIntrinsics::FromHorizontalFov(64, 48, 1.0);
  for (int trial = 0; trial < 20; ++trial, ++g_cases) {
    cv::Mat depth(48, 64, CV_32FC1);
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 64; ++x) {
        const double r = u(rng);
        float d = static_cast<float>(2.0 + 0.01 * x + 0.02 * y);
        if (r < 0.05)
          d = std::nanf("");
        else if (r < 0.07)
          d = std::numeric_limits<float>::infinity();
        else if (r < 0.08)
          d = -std::numeric_limits<float>::infinity();
        else if (r < 0.12)
          d = 0.0f;
        else if (r < 0.13)
          d = -1.0f;
        else if (r < 0.15)
          d *= 100.0f;
        depth.at<float>(y, x) = d;
      }
    }
    const processing::NormalMap map = processing::EstimateNormals(depth, intrinsics);
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 64; ++x) {
        if (map.valid.at<std::uint8_t>(y, x) == 0) continue;
        const cv::Vec3f n = map.normal_in_camera.at<cv::Vec3f>(y, x);
        ASSERT_TRUE(std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]));
        EXPECT_NEAR(std::sqrt(n.dot(n)), 1.0, 1e-4);
      }
    }
  }
}

}  // namespace
}  // namespace relume
