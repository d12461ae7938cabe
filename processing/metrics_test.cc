// The error measures every pipeline, test and benchmark uses (processing/metrics.h), against
// values worked out by hand.
#include "processing/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace relume::metrics {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(MetricsTest, SunRegionsSplitAtOnePerCentAndNinetyNine) {
  EXPECT_EQ(ClassifySunRegion(1.0f, 1.0f), SunRegion::kLit);
  EXPECT_EQ(ClassifySunRegion(0.99f, 0.995f), SunRegion::kLit);
  EXPECT_EQ(ClassifySunRegion(0.0f, 1.0f), SunRegion::kShadow);
  EXPECT_EQ(ClassifySunRegion(0.01f, 0.0f), SunRegion::kShadow);
  EXPECT_EQ(ClassifySunRegion(0.5f, 1.0f), SunRegion::kPenumbra);
  EXPECT_EQ(ClassifySunRegion(1.0f, 0.02f), SunRegion::kPenumbra);
  EXPECT_EQ(ClassifySunRegion(kNaN, 1.0f), SunRegion::kShadow);  // attached shadow
}

// Four pixels: lit, shadow, penumbra, and one the mask leaves out; the estimate is the truth
// times (1 + d) with d = 0.1 (lit), -0.2 (shadow), 0.3 (penumbra).
struct Case {
  cv::Mat estimate = cv::Mat(1, 4, CV_32FC3), truth = cv::Mat(1, 4, CV_32FC3);
  cv::Mat source_sun = (cv::Mat_<float>(1, 4) << 1.0f, 0.0f, 0.5f, 1.0f);
  cv::Mat target_sun = (cv::Mat_<float>(1, 4) << 1.0f, 1.0f, 1.0f, 1.0f);
  cv::Mat use = (cv::Mat_<std::uint8_t>(1, 4) << 255, 255, 255, 0);
  Case() {
    const float d[4] = {0.1f, -0.2f, 0.3f, 5.0f};
    for (int x = 0; x < 4; ++x) {
      const cv::Vec3f t(1.0f + x, 2.0f, 0.5f);
      truth.at<cv::Vec3f>(0, x) = t;
      estimate.at<cv::Vec3f>(0, x) = t * (1.0f + d[x]);
    }
  }
};

TEST(MetricsTest, PerSampleRelativeErrorsPerRegion) {
  const Case c;
  cv::Mat image;
  const SunRegionErrors e =
      CompareSunRegions(c.estimate, c.truth, c.source_sun, c.target_sun, c.use, Scale::kAbsolute, &image);
  EXPECT_DOUBLE_EQ(e.scale, 1.0);
  EXPECT_NEAR(e.lit, 0.1, 1e-6);
  EXPECT_NEAR(e.shadow, 0.2, 1e-6);
  EXPECT_NEAR(e.penumbra, 0.3, 1e-6);
  EXPECT_NEAR(e.all, std::sqrt((0.01 + 0.04 + 0.09) / 3.0), 1e-6);
  EXPECT_EQ(e.lit_pixels + e.shadow_pixels + e.penumbra_pixels, 3);
  EXPECT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.at<cv::Vec3b>(0, 3), cv::Vec3b(0, 0, 0));  // not compared
}

TEST(MetricsTest, TheFittedScaleRemovesAnOverallFactorOnly) {
  Case c;
  const SunRegionErrors absolute =
      CompareSunRegions(c.estimate, c.truth, c.source_sun, c.target_sun, c.use, Scale::kAbsolute);
  c.estimate *= 3.0;  // relative radiance: an unknown overall scale
  const SunRegionErrors fitted =
      CompareSunRegions(c.estimate, c.truth, c.source_sun, c.target_sun, c.use, Scale::kFitted);
  // q = 3 (1 + d); a = sum q / sum q^2 minimises sum (a q - 1)^2.
  const double q[3] = {3.3, 2.4, 3.9};
  const double a = (q[0] + q[1] + q[2]) / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
  EXPECT_NEAR(fitted.scale, a, 1e-6);
  EXPECT_NEAR(fitted.lit, std::abs(a * q[0] - 1.0), 1e-6);
  EXPECT_NEAR(fitted.shadow, std::abs(a * q[1] - 1.0), 1e-6);
  // The fitted errors are never above the unscaled ones of the same relative shape.
  EXPECT_LE(fitted.all, absolute.all + 1e-9);
  // Nothing to compare: scale 0 and no pixels.
  const cv::Mat none = cv::Mat::zeros(1, 4, CV_8UC1);
  const SunRegionErrors empty =
      CompareSunRegions(c.estimate, c.truth, c.source_sun, c.target_sun, none, Scale::kFitted);
  EXPECT_EQ(empty.scale, 0.0);
  EXPECT_EQ(empty.lit_pixels + empty.shadow_pixels + empty.penumbra_pixels, 0);
}

TEST(MetricsTest, SignalRelativeRmsWeighsBrightPixelsAndSkipsNonFinite) {
  cv::Mat truth(1, 3, CV_32FC3), estimate(1, 3, CV_32FC3);
  truth.at<cv::Vec3f>(0, 0) = cv::Vec3f(1, 1, 1);
  truth.at<cv::Vec3f>(0, 1) = cv::Vec3f(3, 3, 3);
  truth.at<cv::Vec3f>(0, 2) = cv::Vec3f(kNaN, 1, 1);
  estimate.at<cv::Vec3f>(0, 0) = cv::Vec3f(2, 1, 1);  // one channel off by 1
  estimate.at<cv::Vec3f>(0, 1) = cv::Vec3f(3, 3, 3);
  estimate.at<cv::Vec3f>(0, 2) = cv::Vec3f(9, 9, 9);  // truth not finite: left out
  const SignalError e = SignalRelativeRms(estimate, truth, cv::Mat(), Scale::kAbsolute);
  EXPECT_EQ(e.pixels, 2);
  EXPECT_NEAR(e.relative_rms, std::sqrt(1.0 / 30.0), 1e-9);  // sum d^2 = 1, sum t^2 = 3 + 27
  // A mask leaving out the wrong pixel: exact.
  const cv::Mat mask = (cv::Mat_<std::uint8_t>(1, 3) << 0, 255, 255);
  EXPECT_NEAR(SignalRelativeRms(estimate, truth, mask, Scale::kAbsolute).relative_rms, 0.0, 1e-12);
  // An overall factor is removed by the fitted scale (a = sum e t / sum e^2).
  const cv::Mat doubled = truth * 2.0;
  const SignalError fitted = SignalRelativeRms(doubled, truth, cv::Mat(), Scale::kFitted);
  EXPECT_NEAR(fitted.scale, 0.5, 1e-9);
  EXPECT_NEAR(fitted.relative_rms, 0.0, 1e-9);
  // Nothing compared: NaN, never a silent 0.
  EXPECT_TRUE(
      std::isnan(SignalRelativeRms(estimate, truth, cv::Mat::zeros(1, 3, CV_8UC1), Scale::kAbsolute).relative_rms));
}

}  // namespace
}  // namespace relume::metrics
