#include "processing/depth_filter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

// A step: left half at 1.0 m, right half at 1.1 m, plus holes.
cv::Mat StepDepth() {
  cv::Mat depth(20, 20, CV_32FC1);
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 20; ++x) depth.at<float>(y, x) = x < 10 ? 1.0f : 1.1f;
  }
  depth.at<float>(5, 5) = NAN;
  depth.at<float>(6, 5) = 0.0f;
  return depth;
}

TEST(DepthFilterTest, KeepsHolesAndDoesNotFillThem) {
  const cv::Mat out = BilateralFilterDepth(StepDepth());
  EXPECT_TRUE(std::isnan(out.at<float>(5, 5)));
  EXPECT_TRUE(std::isnan(out.at<float>(6, 5)));  // 0 is a hole too: it stays a hole (NaN)
  EXPECT_FLOAT_EQ(out.at<float>(5, 4), 1.0f);    // neighbour of a hole: unaffected by it
}

TEST(DepthFilterTest, DoesNotAverageAcrossADepthStep) {
  BilateralDepthOptions options;
  options.radius_px = 3;
  options.range_sigma_at_1m_m = 0.05;  // 10 cm step = 2 sigma: the Gaussian alone would leak
  options.edge_cut_sigmas = 1.5;
  const cv::Mat out = BilateralFilterDepth(StepDepth(), options);
  for (int y = 0; y < 20; ++y) {
    EXPECT_FLOAT_EQ(out.at<float>(y, 9), 1.0f) << y;
    EXPECT_FLOAT_EQ(out.at<float>(y, 10), 1.1f) << y;
  }
}

TEST(DepthFilterTest, ReducesKinectNoiseOnAPlane) {
  cv::Mat truth(60, 80, CV_32FC1, cv::Scalar(1.2f));
  const cv::Mat noisy = testing::AddKinectDepthNoise(truth, 3);
  const cv::Mat out = BilateralFilterDepth(noisy);
  const double sigma = testing::KinectDepthSigmaM(1.2);
  const double before = cv::norm(noisy, truth) / std::sqrt(truth.total());
  const double after = cv::norm(out, truth) / std::sqrt(truth.total());
  EXPECT_NEAR(before, sigma, 0.1 * sigma);
  EXPECT_LT(after, 0.45 * before);
}

TEST(DepthFilterTest, NoiseEstimateSeesNoiseButNotSurfaces) {
  // A slanted plane, a sphere cap and a crease at 1.0-1.6 m, as an RGB-D sensor sees them.
  cv::Mat exact(120, 160, CV_32FC1);
  for (int y = 0; y < exact.rows; ++y) {
    for (int x = 0; x < exact.cols; ++x) {
      const double u = (x - 80) / 100.0, v = (y - 60) / 100.0;
      double z = 1.3 + 0.4137 * u + 0.1173 * v + 0.2 * std::abs(u - 0.3);  // plane with a crease
      const double r2 = (u + 0.4) * (u + 0.4) + v * v;
      if (r2 < 0.09) z -= std::sqrt(0.09 - r2) * 0.8;  // a bump: a silhouette-free sphere cap
      exact.at<float>(y, x) = static_cast<float>(z);
    }
  }
  exact.at<float>(10, 10) = NAN;
  const DepthNoiseEstimate clean = EstimateDepthNoise(exact);
  EXPECT_GT(clean.samples, 30000);
  EXPECT_LT(clean.sigma_at_1m_m, 2e-6);  // float rounding and the odd crease window only
  EXPECT_TRUE(clean.NoiseFree(kDenoiseSkipBelowAt1mM)) << clean.Describe();

  cv::Mat millimetres = exact.clone();
  for (auto it = millimetres.begin<float>(); it != millimetres.end<float>(); ++it) *it = std::round(*it * 1000) / 1000;
  // Rounding to 1 mm: sigma 1 / sqrt(12) mm = 0.29 mm at ~1.3 m, 0.17 mm at 1 m.
  const double mm = EstimateDepthNoise(millimetres).sigma_at_1m_m;
  std::cout << "noise at 1 m: exact " << clean.sigma_at_1m_m << ", millimetres " << mm;
  EXPECT_GT(mm, 0.08e-3);
  EXPECT_LT(mm, 0.25e-3);
  EXPECT_FALSE(EstimateDepthNoise(millimetres).NoiseFree(kDenoiseSkipBelowAt1mM));

  // Coarse steps (a structured-light sensor's disparity steps far away): flat between steps,
  // so the fourth differences see almost nothing, but the steps are there.
  cv::Mat steps = exact.clone();
  for (auto it = steps.begin<float>(); it != steps.end<float>(); ++it) *it = std::round(*it * 20) / 20;  // 5 cm
  const DepthNoiseEstimate coarse = EstimateDepthNoise(steps);
  EXPECT_LT(coarse.sigma_at_1m_m, kDenoiseSkipBelowAt1mM) << "fooled, as expected: " << coarse.Describe();
  EXPECT_GT(coarse.stair_fraction, 0.5);
  EXPECT_FALSE(coarse.NoiseFree(kDenoiseSkipBelowAt1mM)) << coarse.Describe();

  const cv::Mat noisy = testing::AddKinectDepthNoise(exact, 11);
  // Kinect-like noise: sigma(z) / z^2 over these depths (1.2 mm at 0.4 m + quadratic growth).
  const double kinect = EstimateDepthNoise(noisy).sigma_at_1m_m;
  EXPECT_FALSE(EstimateDepthNoise(noisy).NoiseFree(kDenoiseSkipBelowAt1mM));
  const double expected = testing::KinectDepthSigmaM(1.3) / (1.3 * 1.3);
  std::cout << ", Kinect " << kinect << " (model at 1.3 m: " << expected << ")\n";
  EXPECT_NEAR(kinect, expected, 0.25 * expected);

  EXPECT_EQ(EstimateDepthNoise(cv::Mat(4, 4, CV_32FC1, cv::Scalar(NAN))).samples, 0);
  EXPECT_THROW(EstimateDepthNoise(cv::Mat(4, 4, CV_16UC1)), InvalidArgumentError);
}

TEST(DepthFilterTest, TemporalBlendFollowsEquationTwoWhereClose) {
  cv::Mat current(2, 2, CV_32FC1, cv::Scalar(1.0f)), previous(2, 2, CV_32FC1, cv::Scalar(1.003f));
  previous.at<float>(0, 1) = 1.5f;  // moved: not blended
  previous.at<float>(1, 0) = NAN;   // hole in the previous frame
  current.at<float>(1, 1) = NAN;    // hole now: stays a hole
  TemporalDepthOptions options;
  options.weight = 2.0;
  int blended = 0;
  const cv::Mat out = TemporalFilterDepth(current, previous, options, &blended);
  EXPECT_EQ(blended, 1);
  EXPECT_NEAR(out.at<float>(0, 0), (1.0 * 3 + 1.003 * 2) / 5, 1e-6);
  EXPECT_FLOAT_EQ(out.at<float>(0, 1), 1.0f);
  EXPECT_FLOAT_EQ(out.at<float>(1, 0), 1.0f);
  EXPECT_TRUE(std::isnan(out.at<float>(1, 1)));
}

TEST(DepthFilterTest, DenoiserBlendsFromTheSecondFrame) {
  DepthDenoiser denoiser({}, {});
  cv::Mat truth(30, 30, CV_32FC1, cv::Scalar(1.0f));
  denoiser.Process(testing::AddKinectDepthNoise(truth, 1));
  EXPECT_EQ(denoiser.last_blended_pixel_count(), 0);
  const cv::Mat second = denoiser.Process(testing::AddKinectDepthNoise(truth, 2));
  EXPECT_GT(denoiser.last_blended_pixel_count(), 850);
  const cv::Mat single = BilateralFilterDepth(testing::AddKinectDepthNoise(truth, 2));
  EXPECT_LT(cv::norm(second, truth), cv::norm(single, truth));
}

TEST(DepthFilterTest, RejectsBadOptionsAndTypes) {
  BilateralDepthOptions bad;
  bad.radius_px = -1;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_THROW(BilateralFilterDepth(StepDepth(), bad), InvalidArgumentError);
  EXPECT_THROW(BilateralFilterDepth(cv::Mat::zeros(4, 4, CV_16UC1)), InvalidArgumentError);
  TemporalDepthOptions temporal;
  EXPECT_THROW(TemporalFilterDepth(StepDepth(), cv::Mat(3, 3, CV_32FC1, cv::Scalar(1.0f)), temporal),
               InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
