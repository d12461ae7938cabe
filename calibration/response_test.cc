#include "calibration/response.h"

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

Bracket MakeBracket(ResponseShape shape, int count, double stops, double shot_noise = 0.0, double range = 1e4) {
  Bracket b;
  testing::SceneOptions scene;
  scene.width = 160;
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

// Largest relative error of the recovered inverse against the truth over codes [lo, hi].
double CurveError(const CameraResponse& recovered, ResponseShape shape, int lo = 16, int hi = 240) {
  const CameraResponse truth = testing::TrueInverseResponse(SyntheticResponse{shape});
  double worst = 0.0;
  for (int c = 0; c < 3; ++c) {
    for (int z = lo; z <= hi; ++z) {
      worst = std::max(worst, std::abs(recovered.inverse[c][z] / truth.inverse[c][z] - 1.0));
    }
  }
  return worst;
}

TEST(ResponseTest, DebevecRecoversGamma) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 5, 1.5);
  const ResponseResult r = RecoverResponse(b.frames, b.times);
  ASSERT_TRUE(r.summary.usable) << r.summary.BriefReport();
  EXPECT_TRUE(r.summary.converged);
  EXPECT_GT(r.summary.samples_used, 100);
  EXPECT_GT(r.summary.condition, 1.0);
  EXPECT_LT(CurveError(r.response, ResponseShape::kGamma), 0.03) << r.summary.BriefReport();
}

TEST(ResponseTest, DebevecRecoversTableWithNoise) {
  const Bracket b = MakeBracket(ResponseShape::kTable, 5, 1.5, 1e-4);
  const ResponseResult r = RecoverResponse(b.frames, b.times);
  ASSERT_TRUE(r.summary.usable) << r.summary.BriefReport();
  // The smoothness term rounds the table's kinks: a few percent at the knots.
  EXPECT_LT(CurveError(r.response, ResponseShape::kTable, 24, 235), 0.08) << r.summary.BriefReport();
}

TEST(ResponseTest, RobertsonRecoversSCurveAndReportsIterations) {
  // Irregular exposure ratios: with one constant ratio r between frames the curve is only
  // determined up to a factor periodic in log X with period log r, which Robertson's
  // iteration (unlike Debevec's smoothness term) does not resolve.
  Bracket b = MakeBracket(ResponseShape::kSCurve, 1, 1.0);
  b.times = {0.25, 0.6, 1.0, 2.7, 5.0};
  for (double& t : b.times) t *= 18.0;
  b.frames = testing::RenderBracket(b.radiance, b.times, SyntheticResponse{ResponseShape::kSCurve}, {});
  ResponseOptions options;
  options.method = ResponseMethod::kRobertson;
  const ResponseResult r = RecoverResponse(b.frames, b.times, options);
  ASSERT_TRUE(r.summary.usable) << r.summary.BriefReport();
  EXPECT_TRUE(r.summary.converged) << r.summary.BriefReport();
  EXPECT_GT(r.summary.iterations, 1);
  EXPECT_LT(CurveError(r.response, ResponseShape::kSCurve, 24, 235), 0.04) << r.summary.BriefReport();
}

TEST(ResponseTest, RobertsonIterationLimitIsReportedNotHidden) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 3, 2.0);
  ResponseOptions options;
  options.method = ResponseMethod::kRobertson;
  options.robertson_max_iterations = 2;
  options.robertson_tolerance = 1e-12;
  const ResponseResult r = RecoverResponse(b.frames, b.times, options);
  EXPECT_FALSE(r.summary.converged);
  EXPECT_EQ(r.summary.iterations, 2);
  EXPECT_NE(r.summary.reason.find("iteration limit"), std::string::npos);
}

TEST(ResponseTest, ExposuresOutOfOrderGiveTheSameCurve) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 4, 2.0);
  const ResponseResult sorted = RecoverResponse(b.frames, b.times);
  const std::vector<CameraImage> shuffled = {b.frames[2], b.frames[0], b.frames[3], b.frames[1]};
  const std::vector<double> times = {b.times[2], b.times[0], b.times[3], b.times[1]};
  const ResponseResult r = RecoverResponse(shuffled, times);
  for (int c = 0; c < 3; ++c) {
    for (int z = 0; z < 256; ++z) EXPECT_NEAR(r.response.inverse[c][z], sorted.response.inverse[c][z], 1e-9);
  }
}

TEST(ResponseTest, DuplicatedExposureIsAccepted) {
  Bracket b = MakeBracket(ResponseShape::kGamma, 4, 2.0);
  b.frames.push_back(b.frames[1]);
  b.times.push_back(b.times[1]);
  const ResponseResult r = RecoverResponse(b.frames, b.times);
  ASSERT_TRUE(r.summary.usable);
  EXPECT_LT(CurveError(r.response, ResponseShape::kGamma), 0.03);
}

TEST(ResponseTest, BracketOfOneFrameIsAClearError) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 1, 1.0);
  EXPECT_THROW(RecoverResponse(b.frames, b.times), InvalidArgumentError);
}

TEST(ResponseTest, EqualExposuresAreFlaggedUnusable) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 3, 0.0);
  const ResponseResult r = RecoverResponse(b.frames, b.times);
  EXPECT_FALSE(r.summary.usable);
  EXPECT_NE(r.summary.reason.find("equal"), std::string::npos);
}

TEST(ResponseTest, EveryFrameSaturatesSomewhere) {
  // A 1e5 range seen through 3 frames 2 stops apart: every frame clips some patches.
  const Bracket b = MakeBracket(ResponseShape::kGamma, 3, 2.0, 0.0, 1e5);
  for (const auto& f : b.frames) {
    double max_value = 0.0;
    cv::minMaxLoc(f.pixels.reshape(1), nullptr, &max_value);
    ASSERT_EQ(max_value, 255.0);
  }
  const ResponseResult r = RecoverResponse(b.frames, b.times);
  ASSERT_TRUE(r.summary.usable) << r.summary.BriefReport();
  EXPECT_LT(CurveError(r.response, ResponseShape::kGamma, 24, 235), 0.04);
}

TEST(ResponseTest, FramesSaturatedEverywhereAreFlaggedUnusable) {
  std::vector<CameraImage> frames(3);
  for (auto& f : frames) f.pixels = cv::Mat(32, 32, CV_8UC3, cv::Scalar(255, 255, 255));
  const ResponseResult r = RecoverResponse(frames, {0.1, 0.2, 0.4});
  EXPECT_FALSE(r.summary.usable);
  EXPECT_FALSE(r.summary.reason.empty());
  EXPECT_TRUE(r.response.inverse.empty());
}

TEST(ResponseTest, RejectsMismatchedFrames) {
  Bracket b = MakeBracket(ResponseShape::kGamma, 3, 1.0);
  EXPECT_THROW(RecoverResponse(b.frames, {0.1, 0.2}), InvalidArgumentError);
  EXPECT_THROW(RecoverResponse(b.frames, {0.1, -0.2, 0.3}), InvalidArgumentError);
  b.frames[1].pixels = b.frames[1].pixels(cv::Rect(0, 0, 10, 10)).clone();
  EXPECT_THROW(RecoverResponse(b.frames, b.times), InvalidArgumentError);
}

TEST(ResponseTest, OptionsValidation) {
  ResponseOptions options;
  std::string why;
  EXPECT_TRUE(options.IsValid(&why));
  options.sample_count = 2;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("sample_count"), std::string::npos);
  options = {};
  options.lambda = -1.0;
  EXPECT_FALSE(options.IsValid(&why));
  options = {};
  options.max_prior_disagreement = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("max_prior_disagreement"), std::string::npos);
  options.max_prior_disagreement = std::nan("");
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_THROW(ResponseMethodFromString("bogus"), InvalidArgumentError);
  EXPECT_THROW(ResponseSmoothnessFromString("bogus"), InvalidArgumentError);
  for (ResponseSmoothness s : {ResponseSmoothness::kCode, ResponseSmoothness::kLogCode}) {
    EXPECT_EQ(ResponseSmoothnessFromString(ToString(s)), s);
  }
}

TEST(ResponseTest, EvBracketRefinesScaleFactors) {
  // An EV-only camera: nominal EV -2..2, but the true shutter ratios are off by up to 9%.
  testing::SceneOptions scene;
  scene.width = 160;
  scene.height = 128;
  scene.dynamic_range = 3e3;
  const cv::Mat radiance = testing::MakeHdrRadiance(scene);
  const std::vector<double> ev = {-2, -1, 0, 1, 2};
  const std::vector<double> skew = {1.09, 0.95, 1.0, 1.06, 0.93};
  std::vector<double> true_times;
  for (std::size_t i = 0; i < ev.size(); ++i) true_times.push_back(0.18 * std::sqrt(3e3) * std::exp2(ev[i]) * skew[i]);
  const auto frames = testing::RenderBracket(radiance, true_times, SyntheticResponse{ResponseShape::kGamma}, {});
  const EvCalibration cal = RecoverResponseFromEv(frames, ev);
  ASSERT_TRUE(cal.result.summary.usable) << cal.result.summary.BriefReport();
  // Ratios are recoverable up to a common exponent g (X^g, t^g fit the same frames): compare
  // log ratios after the best g, and require the deviations from the EV ladder to be found.
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const double est = std::log(cal.exposure_times_s[i] / cal.exposure_times_s[2]);
    const double truth = std::log(true_times[i] / true_times[2]);
    num += est * truth;
    den += truth * truth;
  }
  const double g = num / den;
  EXPECT_NEAR(g, 1.0, 0.1);
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const double est = std::log(cal.exposure_times_s[i] / cal.exposure_times_s[2]);
    const double truth = std::log(true_times[i] / true_times[2]);
    EXPECT_NEAR(est, g * truth, 0.02) << "frame " << i;  // the skew is 0.05..0.09
  }
}

// Exposures 4 stops apart: the data fix g only up to a function periodic in ln X with period
// ln 16, and for the S curve no pixel puts codes ~25..105 in two well-exposed frames at all,
// so the curve there is the smoothness prior's. The summary must say so.
TEST(ResponseTest, SparseBracketIsFlaggedLowConfidence) {
  const Bracket b = MakeBracket(ResponseShape::kSCurve, 3, 4.0, 2e-5);
  const ResponseResult r = RecoverResponse(b.frames, b.times);
  ASSERT_TRUE(r.summary.usable) << r.summary.BriefReport();
  ASSERT_TRUE(r.summary.prior_disagreement.has_value());
  EXPECT_GT(*r.summary.prior_disagreement, 0.1) << r.summary.BriefReport();
  EXPECT_TRUE(r.summary.low_confidence);
  EXPECT_NE(r.summary.reason.find("smoothness priors"), std::string::npos) << r.summary.reason;
}

TEST(ResponseTest, DenseBracketIsNotFlagged) {
  for (ResponseShape shape : {ResponseShape::kGamma, ResponseShape::kSCurve}) {
    const Bracket b = MakeBracket(shape, 9, 1.0, 2e-5);
    const ResponseResult r = RecoverResponse(b.frames, b.times);
    ASSERT_TRUE(r.summary.usable) << r.summary.BriefReport();
    ASSERT_TRUE(r.summary.prior_disagreement.has_value());
    EXPECT_LT(*r.summary.prior_disagreement, 0.01) << testing::ToString(shape) << ": " << r.summary.BriefReport();
    EXPECT_FALSE(r.summary.low_confidence) << r.summary.reason;
  }
}

TEST(ResponseTest, RobertsonHasNoPriorDisagreement) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 5, 1.5);
  ResponseOptions options;
  options.method = ResponseMethod::kRobertson;
  const ResponseResult r = RecoverResponse(b.frames, b.times, options);
  ASSERT_TRUE(r.summary.usable);
  EXPECT_FALSE(r.summary.prior_disagreement.has_value());
}

// Debevec's term as it was before log-code became the default.
ResponseOptions CodeSmoothnessOptions() {
  ResponseOptions options;
  options.smoothness = ResponseSmoothness::kCode;
  options.lambda = 40.0;
  return options;
}

// A power law is in the null space of the log-code smoothness term (the default), so a
// 3-frame bracket 4 stops apart recovers a gamma curve where the code term (whose null space
// is exponential curves) bends it.
TEST(ResponseTest, LogCodeSmoothnessRecoversSparseGammaBracket) {
  const Bracket b = MakeBracket(ResponseShape::kGamma, 3, 4.0);
  const ResponseResult log_code = RecoverResponse(b.frames, b.times);
  const ResponseResult code = RecoverResponse(b.frames, b.times, CodeSmoothnessOptions());
  ASSERT_TRUE(log_code.summary.usable) << log_code.summary.BriefReport();
  ASSERT_TRUE(code.summary.usable);
  const double log_code_error = CurveError(log_code.response, ResponseShape::kGamma, 24, 235);
  const double code_error = CurveError(code.response, ResponseShape::kGamma, 24, 235);
  EXPECT_LT(log_code_error, 0.01) << log_code.summary.BriefReport();  // measured 0.47 % (code term: 2.7 %)
  EXPECT_LT(log_code_error, code_error);
}

// Degenerate brackets under either smoothness term: a clear "not usable" or a valid curve,
// never NaN.
TEST(ResponseTest, DegenerateBracketsGiveNoNaNWithEitherSmoothness) {
  std::vector<std::vector<CameraImage>> brackets;
  const auto uniform = [](int code) {
    CameraImage f;
    f.pixels = cv::Mat(32, 32, CV_8UC3, cv::Scalar::all(code));
    return f;
  };
  brackets.push_back({uniform(0), uniform(0), uniform(0)});        // black everywhere
  brackets.push_back({uniform(255), uniform(255), uniform(255)});  // saturated everywhere
  brackets.push_back({uniform(90), uniform(120), uniform(160)});   // a flat scene
  // Two frames 10 stops apart: almost nothing is well exposed in both.
  const Bracket wide = MakeBracket(ResponseShape::kGamma, 2, 10.0, 2e-5);
  brackets.push_back(wide.frames);
  // A mono ramp: few distinct codes per frame.
  std::vector<CameraImage> ramp(3);
  for (int j = 0; j < 3; ++j) {
    ramp[j].layout = ColorLayout::kMono;
    ramp[j].pixels = cv::Mat(16, 16, CV_8UC1);
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x)
        ramp[j].pixels.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(std::min(255, (x + 1) * 8 * (j + 1)));
    }
  }
  brackets.push_back(ramp);
  for (ResponseSmoothness smoothness : {ResponseSmoothness::kCode, ResponseSmoothness::kLogCode}) {
    ResponseOptions options;
    options.smoothness = smoothness;
    for (std::size_t i = 0; i < brackets.size(); ++i) {
      const std::vector<double> times = brackets[i].size() == 2 ? wide.times : std::vector<double>{0.1, 0.2, 0.4};
      const ResponseResult r = RecoverResponse(brackets[i], times, options);
      SCOPED_TRACE(std::string(ToString(smoothness)) + ", bracket " + std::to_string(i) + ": " +
                   r.summary.BriefReport());
      EXPECT_TRUE(std::isfinite(r.summary.residual));
      if (r.summary.prior_disagreement) {
        EXPECT_TRUE(std::isfinite(*r.summary.prior_disagreement));
      }
      if (!r.summary.usable) {
        EXPECT_FALSE(r.summary.reason.empty());
        EXPECT_TRUE(r.response.inverse.empty());
        continue;
      }
      std::string why;
      EXPECT_TRUE(r.response.IsValid(&why)) << why;
      if (i == 3) {
        EXPECT_TRUE(r.summary.low_confidence);  // 10 stops apart: the prior decides
      }
    }
  }
}

TEST(ResponseTest, FitScaleFactorRecoversAKnownScale) {
  cv::Mat reference(20, 20, CV_32FC3), values(20, 20, CV_32FC3);
  cv::randu(reference, 0.1, 2.0);
  values = reference / 2.5;
  const ScaleFit fit = FitScaleFactor(values, reference);
  ASSERT_TRUE(fit.usable);
  EXPECT_NEAR(fit.scale, 2.5, 1e-5);
  EXPECT_LT(fit.relative_rms, 1e-5);
}

TEST(ResponseTest, FitScaleFactorWithoutOverlapIsUnusable) {
  cv::Mat a(8, 8, CV_32FC1, cv::Scalar(1.0)), b(8, 8, CV_32FC1, cv::Scalar(2.0));
  const ScaleFit fit = FitScaleFactor(a, b, cv::Mat::zeros(8, 8, CV_8UC1));
  EXPECT_FALSE(fit.usable);
  EXPECT_EQ(fit.scale, 1.0);
  EXPECT_FALSE(fit.reason.empty());
}

TEST(ResponseTest, LinearResponseForSensorCounts) {
  const CameraResponse r = CameraResponse::Linear(1, 4096, 256, 4095);
  EXPECT_TRUE(r.IsValid(nullptr));
  EXPECT_EQ(r.inverse[0][100], 0.0);
  EXPECT_NEAR(r.inverse[0][256 + 3839 / 2], (3839 / 2) / 3839.0, 1e-12);
  EXPECT_NEAR(r.inverse[0][4095], 1.0, 1e-12);
}

}  // namespace
}  // namespace relume::calibration
