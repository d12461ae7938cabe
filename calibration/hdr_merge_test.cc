#include "calibration/hdr_merge.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "calibration/testing/synthetic_bracket.h"
#include "core/error.h"

namespace relume::calibration {
namespace {

using testing::ResponseShape;
using testing::SyntheticResponse;

struct Bracket {
  cv::Mat radiance;
  std::vector<double> times;
  std::vector<CameraImage> frames;
};

Bracket MakeBracket(ResponseShape shape, int count, double stops, double shot_noise, double range = 1e4) {
  Bracket b;
  testing::SceneOptions scene;
  scene.width = 192;
  scene.height = 128;
  scene.dynamic_range = range;
  b.radiance = testing::MakeHdrRadiance(scene);
  b.times = testing::BracketExposures(count, stops, 0.18 * std::sqrt(range));
  testing::NoiseOptions noise;
  noise.shot_noise = shot_noise;
  noise.read_noise = shot_noise > 0.0 ? 2e-4 : 0.0;
  b.frames = testing::RenderBracket(b.radiance, b.times, SyntheticResponse{shape}, noise);
  return b;
}

bool AllFinite(const cv::Mat& m) {
  return cv::checkRange(m, true, nullptr, -1e30, 1e30);
}

TEST(HdrMergeTest, TrueResponseMeetsOnePercentWhereWellExposed) {
  for (ResponseShape shape : {ResponseShape::kGamma, ResponseShape::kSCurve, ResponseShape::kTable}) {
    const Bracket b = MakeBracket(shape, 5, 2.0, 1e-5);
    const HdrMergeResult r = MergeHdr(b.frames, b.times, testing::TrueInverseResponse(SyntheticResponse{shape}));
    const cv::Mat mask = testing::WellExposedMask(b.radiance, b.times, SyntheticResponse{shape});
    const testing::RadianceError e = testing::CompareRadiance(r.radiance.pixels, b.radiance, mask);
    EXPECT_GT(e.pixels, 1000);
    EXPECT_LT(e.mean_relative, 0.01) << testing::ToString(shape);
    EXPECT_TRUE(AllFinite(r.radiance.pixels));
  }
}

TEST(HdrMergeTest, RecoveredResponseMeetsOnePercentWhereWellExposed) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 5, 2.0, 1e-5);
  const ResponseResult rr = RecoverResponse(b.frames, b.times);
  ASSERT_TRUE(rr.summary.usable);
  const HdrMergeResult r = MergeHdr(b.frames, b.times, rr.response);
  const cv::Mat mask = testing::WellExposedMask(b.radiance, b.times, SyntheticResponse{ResponseShape::kGamma});
  const testing::RadianceError e = testing::CompareRadiance(r.radiance.pixels, b.radiance, mask);
  EXPECT_LT(e.mean_relative, 0.01);
}

// Three frames 4 stops apart over 8 stops, with sensor noise: the sparse case of issue 6.
// Even the true response leaves about 1.1 % here (pixels well exposed in one frame only, at
// low codes); a curve recovered with the log-code smoothness stays close to that.
TEST(HdrMergeTest, SparseThreeFrameGammaBracketWithLogCodeSmoothness) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 3, 4.0, 2e-5);
  const cv::Mat mask = testing::WellExposedMask(b.radiance, b.times, SyntheticResponse{ResponseShape::kGamma});
  const testing::RadianceError truth = testing::CompareRadiance(
      MergeHdr(b.frames, b.times, testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma}))
          .radiance.pixels,
      b.radiance, mask);
  const ResponseResult rr = RecoverResponse(b.frames, b.times);  // log-code smoothness, the default
  ASSERT_TRUE(rr.summary.usable) << rr.summary.BriefReport();
  const HdrMergeResult r = MergeHdr(b.frames, b.times, rr.response);
  const testing::RadianceError e = testing::CompareRadiance(r.radiance.pixels, b.radiance, mask);
  ResponseOptions code_options;  // Debevec's term and weight before log-code became the default
  code_options.smoothness = ResponseSmoothness::kCode;
  code_options.lambda = 40.0;
  const ResponseResult code = RecoverResponse(b.frames, b.times, code_options);
  const testing::RadianceError e_code =
      testing::CompareRadiance(MergeHdr(b.frames, b.times, code.response).radiance.pixels, b.radiance, mask);
  EXPECT_GT(e.pixels, 1000);
  EXPECT_LT(e.mean_relative, 0.014);  // measured 1.09 % (true response 0.95 %, code term 1.55 %)
  EXPECT_LT(e.mean_relative, truth.mean_relative + 0.004);
  EXPECT_LT(e.mean_relative, e_code.mean_relative);
  EXPECT_TRUE(AllFinite(r.radiance.pixels));
}

TEST(HdrMergeTest, ContributorsMarkWellExposedFrames) {
  // One pixel: code 0 in frame 0 (black), 128 in frame 1, 255 in frame 2 (saturated).
  std::vector<CameraImage> frames(3);
  const int codes[3] = {0, 128, 255};
  for (int j = 0; j < 3; ++j) frames[j].pixels = cv::Mat(2, 2, CV_8UC3, cv::Scalar::all(codes[j]));
  const CameraResponse response = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma});
  const HdrMergeResult r = MergeHdr(frames, {0.01, 0.02, 0.04}, response);
  EXPECT_EQ(r.contributors.at<std::uint16_t>(0, 0), 0b010);
  EXPECT_EQ(r.status.at<std::uint8_t>(0, 0), kHdrGood);
  EXPECT_NEAR(r.radiance.pixels.at<cv::Vec3f>(0, 0)[1], 1.0 / 0.02, 1e-3);
}

TEST(HdrMergeTest, SaturatedInEveryFrameGivesAFlaggedLowerBound) {
  std::vector<CameraImage> frames(2);
  for (auto& f : frames) f.pixels = cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(255));
  frames[0].pixels.at<cv::Vec3b>(0, 0) = cv::Vec3b(100, 100, 100);
  const CameraResponse response = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma});
  const HdrMergeResult r = MergeHdr(frames, {0.01, 0.1}, response);
  EXPECT_EQ(r.status.at<std::uint8_t>(1, 1), kHdrSaturatedLowerBound);
  EXPECT_EQ(r.contributors.at<std::uint16_t>(1, 1), 0);
  EXPECT_NEAR(r.radiance.pixels.at<cv::Vec3f>(1, 1)[0], response.inverse[0][255] / 0.01, 1e-2);
  EXPECT_EQ(r.summary.pixels_saturated_everywhere, 15);
  EXPECT_NE(r.summary.reason.find("shorter exposure"), std::string::npos);
  EXPECT_TRUE(AllFinite(r.radiance.pixels));
}

TEST(HdrMergeTest, BlackInEveryFrameGivesAFlaggedUpperBound) {
  std::vector<CameraImage> frames(2);
  for (auto& f : frames) f.pixels = cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(0));
  const CameraResponse response = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma});
  const HdrMergeResult r = MergeHdr(frames, {0.01, 0.1}, response);
  EXPECT_EQ(r.status.at<std::uint8_t>(2, 2), kHdrBlackUpperBound);
  EXPECT_EQ(r.radiance.pixels.at<cv::Vec3f>(2, 2)[2], 0.0f);
  EXPECT_EQ(r.summary.pixels_black_everywhere, 16);
}

TEST(HdrMergeTest, BracketOfOneFrameIsTheLinearisedFrame) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 1, 1.0, 0.0);
  const CameraResponse response = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kGamma});
  const HdrMergeResult r = MergeHdr(b.frames, b.times, response);
  const cv::Vec3b code = b.frames[0].pixels.at<cv::Vec3b>(50, 60);
  if (code[0] > 4 && code[0] < 250) {
    EXPECT_NEAR(r.radiance.pixels.at<cv::Vec3f>(50, 60)[0], response.inverse[0][code[0]] / b.times[0], 1e-3);
  }
  EXPECT_TRUE(AllFinite(r.radiance.pixels));
}

TEST(HdrMergeTest, ThreadCountDoesNotChangeTheResult) {
  const Bracket b = MakeBracket(ResponseShape::kSCurve, 4, 2.0, 1e-5);
  const CameraResponse response = testing::TrueInverseResponse(SyntheticResponse{ResponseShape::kSCurve});
  HdrMergeOptions one, four;
  one.threads = 1;
  four.threads = 4;
  const HdrMergeResult a = MergeHdr(b.frames, b.times, response, one);
  const HdrMergeResult c = MergeHdr(b.frames, b.times, response, four);
  EXPECT_EQ(cv::norm(a.radiance.pixels, c.radiance.pixels, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.contributors, c.contributors, cv::NORM_INF), 0.0);
  EXPECT_EQ(c.summary.threads_used, 4);
}

TEST(HdrMergeTest, SensorLinear16BitWithBlackLevel) {
  // 12-bit counts, black 256, white 4000; radiance 1000 counts/s seen at 0.1 s and 1 s.
  std::vector<CameraImage> frames(2);
  const double times[2] = {0.1, 1.0};
  for (int j = 0; j < 2; ++j) {
    CameraImage& f = frames[j];
    f.pixels = cv::Mat(4, 4, CV_16UC1, cv::Scalar(std::min(4095.0, 256 + 1000 * times[j])));
    f.layout = ColorLayout::kMono;
    f.encoding = SampleEncoding::kSensorLinear;
    f.bits_per_sample = 12;
    f.black_level = 256;
    f.white_level = 4000;
  }
  const HdrMergeResult r = MergeHdr(frames, {0.1, 1.0}, SensorLinearResponse(frames[0]));
  // Relative units: X = counts above black / (white - black), divided by t.
  EXPECT_NEAR(r.radiance.pixels.at<float>(0, 0), 1000.0 / 3744.0, 1e-5);
  EXPECT_EQ(r.contributors.at<std::uint16_t>(0, 0), 0b11);
}

TEST(HdrMergeTest, RejectsAResponseOfTheWrongShape) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 2, 1.0, 0.0);
  EXPECT_THROW(MergeHdr(b.frames, b.times, CameraResponse::Linear(1, 256, 0, 255)), InvalidArgumentError);
  CameraResponse bad = CameraResponse::Linear(3, 256, 0, 255);
  bad.inverse[1][10] = -1.0;
  EXPECT_THROW(MergeHdr(b.frames, b.times, bad), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::calibration
