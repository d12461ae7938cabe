#include "processing/nonneg_light.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <random>

#include "core/error.h"
#include "processing/relight.h"

namespace relume::processing {
namespace {

// A lamp-lit light as the SH suite draws them: clamped cosines plus a uniform upper-hemisphere
// sky, exact irradiance.
struct Lamps {
  std::vector<Eigen::Vector3d> direction, irradiance;
  Eigen::Vector3d sky = Eigen::Vector3d::Zero();  // radiance
  Eigen::Vector3d up{0.0, -1.0, 0.0};
  Eigen::Vector3d E(const Eigen::Vector3d& n) const {
    Eigen::Vector3d e = std::numbers::pi * sky * (1.0 + n.dot(up)) / 2.0;
    for (std::size_t j = 0; j < direction.size(); ++j) e += irradiance[j] * std::max(0.0, n.dot(direction[j]));
    return e;
  }
};

Lamps KeyFillSky(const Eigen::Vector3d& key, const Eigen::Vector3d& fill) {
  Lamps l;
  l.direction = {key.normalized(), fill.normalized()};
  l.irradiance = {Eigen::Vector3d(3.0, 2.8, 2.5), Eigen::Vector3d(0.5, 0.6, 0.8)};
  l.sky = Eigen::Vector3d(0.05, 0.07, 0.1);
  return l;
}

// Observations at random normals facing the camera (n_z < -0.05), random albedo.
template <class Light>
std::vector<ShObservation> Observe(const Light& light, int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> uniform(0.2, 0.8);
  std::vector<ShObservation> out;
  while (static_cast<int>(out.size()) < count) {
    const Eigen::Vector3d n = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
    if (n.z() > -0.05) continue;
    ShObservation o;
    o.normal = n;
    o.albedo = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    o.radiance = o.albedo.cwiseProduct(light.E(n)) / std::numbers::pi;
    out.push_back(o);
  }
  return out;
}

// Relative RMS of the ratio relighting E_src_true * E_dst_fit / E_src_fit against E_dst_true
// over the observed normals (albedo cancels), pixels under 10 % of the mean fitted source
// irradiance left out as RelightOptions does.
template <class SourceFit, class DestinationFit>
double RatioError(const std::vector<ShObservation>& normals, const Lamps& src, const Lamps& dst,
                  const SourceFit& fit_src, const DestinationFit& fit_dst) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const ShObservation& o : normals) mean += fit_src(o.normal);
  mean /= static_cast<double>(normals.size());
  double error = 0.0, total = 0.0;
  for (const ShObservation& o : normals) {
    const Eigen::Vector3d es = fit_src(o.normal);
    if ((es - 0.1 * mean).minCoeff() < 0.0) continue;
    const Eigen::Vector3d truth = dst.E(o.normal);
    const Eigen::Vector3d relit = src.E(o.normal).cwiseProduct(fit_dst(o.normal)).cwiseQuotient(es);
    error += (relit - truth).squaredNorm();
    total += truth.squaredNorm();
  }
  return std::sqrt(error / total);
}

TEST(NonNegativeLightTest, RecoversALightOnTheGridExactly) {
  const std::vector<Eigen::Vector3d> grid = FibonacciDirections(NonNegativeLightOptions{}.direction_count);
  NonNegativeLight truth;
  for (int j : {3, 80, 201}) {
    truth.directions.push_back(grid[static_cast<std::size_t>(j)]);
    truth.irradiance.push_back(Eigen::Vector3d(1.0 + 0.01 * j, 0.5, 0.25 + 0.005 * j));
  }
  struct {
    const NonNegativeLight& l;
    Eigen::Vector3d E(const Eigen::Vector3d& n) const { return l.Irradiance(n); }
  } light{truth};
  const std::vector<ShObservation> observations = Observe(light, 3000, 7);
  const NonNegativeLightResult fit = FitNonNegativeLight(observations);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.BriefReport();
  EXPECT_TRUE(fit.summary.converged);
  EXPECT_LT(fit.summary.relative_rms_residual, 1e-5);
  // Relative to the brightest observed normal's irradiance (some normals face none of the three).
  double worst = 0.0, brightest = 0.0;
  for (const ShObservation& o : observations) {
    worst = std::max(worst, (fit.light.Irradiance(o.normal) - truth.Irradiance(o.normal)).norm());
    brightest = std::max(brightest, truth.Irradiance(o.normal).norm());
  }
  worst /= brightest;
  EXPECT_LT(worst, 1e-4);
}

// Lamps off the grid, as in a real scene: the ratio relighting from two non-negative fits is
// several times closer than from two order-2 SH fits of the same observations.
TEST(NonNegativeLightTest, FollowsLampTerminatorsThatOrderTwoShCannot) {
  const Lamps src = KeyFillSky({0.6, -0.5, -0.62}, {-0.7, 0.1, -0.7});
  const Lamps dst = KeyFillSky({-0.3, -0.8, -0.5}, {0.8, 0.3, -0.5});
  const std::vector<ShObservation> at_src = Observe(src, 4000, 11), at_dst = Observe(dst, 4000, 12);
  const NonNegativeLightResult nn_src = FitNonNegativeLight(at_src), nn_dst = FitNonNegativeLight(at_dst);
  ASSERT_TRUE(nn_src.summary.usable && nn_dst.summary.usable);
  const ShFitResult sh_src = FitShKnownAlbedo(at_src), sh_dst = FitShKnownAlbedo(at_dst);
  ASSERT_EQ(sh_src.summary.order_used, 2);
  ASSERT_EQ(sh_dst.summary.order_used, 2);
  const double nn = RatioError(
      at_src, src, dst, [&](const Eigen::Vector3d& n) { return nn_src.light.Irradiance(n); },
      [&](const Eigen::Vector3d& n) { return nn_dst.light.Irradiance(n); });
  const double sh = RatioError(
      at_src, src, dst, [&](const Eigen::Vector3d& n) { return ShIrradiance(sh_src.light, n); },
      [&](const Eigen::Vector3d& n) { return ShIrradiance(sh_dst.light, n); });
  std::printf("ratio relighting error: non-negative %.4f, order-2 SH %.4f; %d / %d active directions\n", nn, sh,
              nn_src.summary.active_direction_count, nn_dst.summary.active_direction_count);
  EXPECT_LT(nn, 0.03);
  EXPECT_LT(nn, sh / 3.0);
}

TEST(NonNegativeLightTest, ShProjectionKeepsTheMeanIrradiance) {
  const Lamps lamps = KeyFillSky({0.6, -0.5, -0.62}, {-0.7, 0.1, -0.7});
  const NonNegativeLightResult fit = FitNonNegativeLight(Observe(lamps, 2000, 3));
  ASSERT_TRUE(fit.summary.usable);
  // The mean of max(0, n . d) over the sphere is 1/4, so the mean irradiance is sum w / 4.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& w : fit.light.irradiance) sum += w;
  EXPECT_LT((ShMeanIrradiance(fit.light.ToSh()) - sum / 4.0).norm(), 1e-9 * sum.norm());
  // Each band-1 coefficient is the irradiance-weighted sum of the directions' Y_1m.
  const ShRgb sh = fit.light.ToSh();
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < fit.light.directions.size(); ++j) {
    first += 0.48860251 * fit.light.directions[j].z() * fit.light.irradiance[j];
  }
  EXPECT_LT((sh.row(ShIndex(1, 0)).transpose() - first).norm(), 1e-6 * first.norm());
}

// Unknown albedo: three segments whose albedos start 30 % off (as an SH fit leaves them). The
// alternation recovers their ratios to the reference segment and a light that relights as
// the known-albedo fit does.
TEST(NonNegativeLightTest, SegmentAlbedosAndLightAlternate) {
  const Lamps src = KeyFillSky({0.6, -0.5, -0.62}, {-0.7, 0.1, -0.7});
  const Lamps dst = KeyFillSky({-0.3, -0.8, -0.5}, {0.8, 0.3, -0.5});
  const std::vector<Eigen::Vector3d> albedo = {{0.5, 0.5, 0.5}, {0.2, 0.6, 0.3}, {0.7, 0.3, 0.2}};
  auto observe = [&](const Lamps& light, std::uint64_t seed) {
    std::vector<ShObservation> out = Observe(light, 3000, seed);
    for (std::size_t i = 0; i < out.size(); ++i) {
      out[i].segment = static_cast<int>(i % 3);
      out[i].albedo = albedo[i % 3];
      out[i].radiance = out[i].albedo.cwiseProduct(light.E(out[i].normal)) / std::numbers::pi;
    }
    return out;
  };
  const std::vector<ShObservation> at_src = observe(src, 21), at_dst = observe(dst, 22);
  const std::vector<Eigen::Vector3d> start = {albedo[0], albedo[1] * 1.3, albedo[2] * 0.7};
  const NonNegativeSegmentFitResult fit_src = FitNonNegativeLightSegments(at_src, start, 0, 5);
  const NonNegativeSegmentFitResult fit_dst = FitNonNegativeLightSegments(at_dst, start, 0, 5);
  ASSERT_TRUE(fit_src.fit.summary.usable && fit_dst.fit.summary.usable);
  EXPECT_EQ(fit_src.segment_albedo[0], albedo[0]);  // the reference keeps its albedo
  for (int s = 1; s < 3; ++s) {
    const Eigen::Vector3d ratio =
        fit_src.segment_albedo[static_cast<std::size_t>(s)].cwiseQuotient(albedo[static_cast<std::size_t>(s)]);
    EXPECT_LT((ratio - Eigen::Vector3d::Ones()).cwiseAbs().maxCoeff(), 0.02) << s << ": " << ratio.transpose();
  }
  const double error = RatioError(
      at_src, src, dst, [&](const Eigen::Vector3d& n) { return fit_src.fit.light.Irradiance(n); },
      [&](const Eigen::Vector3d& n) { return fit_dst.fit.light.Irradiance(n); });
  std::printf("segments: ratio relighting error %.4f, albedo %.4f %.4f (true %.4f %.4f)\n", error,
              fit_src.segment_albedo[1].x(), fit_src.segment_albedo[2].y(), albedo[1].x(), albedo[2].y());
  EXPECT_LT(error, 0.03);
  EXPECT_THROW(FitNonNegativeLightSegments(at_src, start, 5, 5), InvalidArgumentError);
}

TEST(NonNegativeLightTest, TooFewObservationsOrNoLightAreNotUsable) {
  const Lamps lamps = KeyFillSky({0.6, -0.5, -0.62}, {-0.7, 0.1, -0.7});
  const NonNegativeLightResult few = FitNonNegativeLight(Observe(lamps, 20, 1));
  EXPECT_FALSE(few.summary.usable);
  EXPECT_NE(few.summary.message.find("observations"), std::string::npos);
  Lamps dark;
  const NonNegativeLightResult none = FitNonNegativeLight(Observe(dark, 500, 2));
  EXPECT_FALSE(none.summary.usable);
  EXPECT_NE(none.summary.message.find("no light"), std::string::npos);
  NonNegativeLightOptions bad;
  bad.direction_count = 2;
  EXPECT_THROW(FitNonNegativeLight(Observe(lamps, 100, 1), bad), InvalidArgumentError);
}

TEST(NonNegativeLightTest, RelightByTheRatioOfTheSourcesIrradiances) {
  NonNegativeLight src, dst;
  src.directions = {Eigen::Vector3d(0, 0, -1)};
  src.irradiance = {Eigen::Vector3d(2.0, 2.0, 2.0)};
  dst.directions = {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0)};
  dst.irradiance = {Eigen::Vector3d(1.0, 2.0, 3.0), Eigen::Vector3d(4.0, 0.0, 0.0)};
  const float s = std::sqrt(0.5f);
  RadianceImage image;
  image.pixels = cv::Mat(1, 2, CV_32FC3, cv::Scalar(0.4f, 0.5f, 0.6f));
  cv::Mat normals(1, 2, CV_32FC3);
  normals.at<cv::Vec3f>(0, 0) = cv::Vec3f(0.0f, 0.0f, -1.0f);
  normals.at<cv::Vec3f>(0, 1) = cv::Vec3f(s, 0.0f, -s);
  RelightOptions per_pixel;
  per_pixel.ratio_radius_px = 0;
  const RelightResult relit = RelightNonNegative(image, normals, {}, src, dst, per_pixel);
  ASSERT_EQ(relit.summary.relit_pixel_count, 2);
  const cv::Vec3f a = relit.relit.pixels.at<cv::Vec3f>(0, 0), b = relit.relit.pixels.at<cv::Vec3f>(0, 1);
  EXPECT_NEAR(a[0], 0.4f * 0.5f, 1e-6);
  EXPECT_NEAR(a[2], 0.6f * 1.5f, 1e-6);
  // At 45 deg: E_src = 2 s, E_dst = (1 + 4) s in red.
  EXPECT_NEAR(b[0], 0.4f * 5.0f / 2.0f, 1e-5);
  EXPECT_NEAR(b[1], 0.5f * 1.0f, 1e-5);
  NonNegativeLight negative = src;
  negative.irradiance[0].x() = -1.0;
  EXPECT_THROW(RelightNonNegative(image, normals, {}, negative, dst, per_pixel), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
