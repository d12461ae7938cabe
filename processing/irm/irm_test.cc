#include "processing/irm/irm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include "core/error.h"

namespace relume::irm {
namespace {

Eigen::Vector3f RandomDirection(std::mt19937& rng) {
  std::normal_distribution<float> g;
  return Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized();
}

TEST(OctahedralTest, RoundTripAndEveryBinUsed) {
  std::mt19937 rng(1);
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3f n = RandomDirection(rng);
    const Eigen::Vector2f uv = OctahedralFromDirection(n);
    ASSERT_TRUE(uv.minCoeff() >= 0.0f && uv.maxCoeff() <= 1.0f);
    EXPECT_LT((DirectionFromOctahedral(uv) - n).norm(), 1e-5f);
  }
  // Poles and the equator's corners.
  for (const Eigen::Vector3f& n :
       {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0, 0, -1), Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(0, -1, 0)}) {
    EXPECT_LT((DirectionFromOctahedral(OctahedralFromDirection(n)) - n).norm(), 1e-6f);
  }
  RatioMap map;
  map.bins = 8;
  std::vector<int> hits(64, 0);
  for (int i = 0; i < 20000; ++i) ++hits[static_cast<std::size_t>(map.BinOf(RandomDirection(rng)))];
  for (int h : hits) EXPECT_GT(h, 20000 / 64 / 4);  // nearly equal-area: no bin starves
}

// Samples made from the sun + sky model itself, with a known truth.
struct Truth {
  Eigen::Vector3f sun_s{0.3f, -0.8f, 0.52f}, sun_t{-0.6f, 0.2f, 0.77f};
  Eigen::Vector3f S_s{9.0f, 8.5f, 8.0f}, K_s{1.0f, 1.1f, 1.4f}, S_t{6.0f, 6.0f, 5.0f}, K_t{1.5f, 1.6f, 2.0f};
  Truth() {
    sun_s.normalize();
    sun_t.normalize();
  }
  Eigen::Vector3f Irradiance(const Eigen::Vector3f& n, float f, bool source) const {
    const Eigen::Vector3f& sun = source ? sun_s : sun_t;
    const float a = f * std::max(0.0f, n.dot(sun));
    const float h = 0.5f * (1.0f + n.z());
    return (source ? S_s : S_t) * a + (source ? K_s : K_t) * h;
  }
  Eigen::Vector3f Ratio(const Eigen::Vector3f& n, float fs, float ft) const {
    return Irradiance(n, ft, false).cwiseQuotient(Irradiance(n, fs, true));
  }
};

std::vector<Sample> MakeSamples(const Truth& truth, int count, bool with_shadows, std::mt19937& rng,
                                bool upper_hemisphere_only = false) {
  std::vector<Sample> samples;
  std::uniform_real_distribution<float> albedo(0.1f, 0.8f);
  std::uniform_int_distribution<int> state(0, 3);
  for (int i = 0; i < count; ++i) {
    Sample s;
    s.normal = RandomDirection(rng);
    if (s.normal.z() < -0.5f) continue;  // ground-facing normals see nothing
    if (upper_hemisphere_only && (s.normal.x() < 0.0f)) continue;
    const int st = with_shadows ? state(rng) : 0;
    s.source_sun = (st == 0 || st == 2) ? 1.0f : 0.0f;
    s.target_sun = (st == 0 || st == 3) ? 1.0f : 0.0f;
    const Eigen::Vector3f rho = Eigen::Vector3f::Constant(albedo(rng));
    s.source_rgb = rho.cwiseProduct(truth.Irradiance(s.normal, s.source_sun, true)) / 3.14159f;
    s.target_rgb = rho.cwiseProduct(truth.Irradiance(s.normal, s.target_sun, false)) / 3.14159f;
    samples.push_back(s);
  }
  return samples;
}

TEST(IrmTest, MapsAndModelRecoverTheTruth) {
  const Truth truth;
  std::mt19937 rng(2);
  const std::vector<Sample> samples = MakeSamples(truth, 60000, true, rng);
  IrmOptions options;
  options.bins = 32;
  const IrmSet set = BuildIrms(samples, truth.sun_s, truth.sun_t, options);
  EXPECT_FALSE(set.single_map);
  ASSERT_TRUE(set.model.valid) << set.model.reason;
  EXPECT_LT(set.model.rms_relative_residual, 1e-4);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(set.model.sun_source[c], truth.S_s[c] / truth.K_s[c], 1e-3f * truth.S_s[c]);
    EXPECT_NEAR(set.model.sky_target[c], truth.K_t[c] / truth.K_s[c], 1e-3f);
  }
  // Every state combination, and the penumbra, through the maps: with the model correction
  // (default) the bins' ratios over the model at their own samples are 1 for data that follow
  // the model, so the result is the model's, exact; without it, bilinear interpolation between
  // bin values.
  IrmOptions plain_options = options;
  plain_options.model_correction = false;
  const IrmSet plain = BuildIrms(samples, truth.sun_s, truth.sun_t, plain_options);
  for (const IrmSet* s : {&set, &plain}) {
    double worst_pure = 0.0, worst_penumbra = 0.0, sum = 0.0;
    std::vector<double> errors;
    for (int i = 0; i < 2000; ++i) {
      Eigen::Vector3f n = RandomDirection(rng);
      if (n.z() < -0.3f) continue;
      for (float fs : {0.0f, 0.37f, 1.0f}) {
        for (float ft : {0.0f, 0.81f, 1.0f}) {
          const Eigen::Vector3f expected = truth.Ratio(n, fs, ft);
          const Eigen::Vector3f got = s->Ratio(n, fs, ft);
          ASSERT_TRUE(got.allFinite());
          const double error = (got - expected).cwiseQuotient(expected).cwiseAbs().maxCoeff();
          const bool pure = (fs == 0.0f || fs == 1.0f) && (ft == 0.0f || ft == 1.0f);
          errors.push_back(error);
          sum += error;
          (pure ? worst_pure : worst_penumbra) = std::max(pure ? worst_pure : worst_penumbra, error);
        }
      }
    }
    std::sort(errors.begin(), errors.end());
    const double p95 = errors[errors.size() * 95 / 100];
    const double mean = sum / static_cast<double>(errors.size());
    std::printf(
        "32x32 bins, model correction %s: relative ratio error mean %.5f, 95th percentile %.5f, worst %.5f (pure "
        "states), %.5f (penumbra)\n",
        s == &set ? "on" : "off", mean, p95, worst_pure, worst_penumbra);
    if (s == &set) {
      EXPECT_LT(mean, 1e-4);
      EXPECT_LT(worst_pure, 1e-3);
    } else {
      // Bins are 1/32 of the square wide and interpolated; the ratio bends sharply where a
      // normal turns away from the sun, so the worst cases sit there.
      EXPECT_LT(mean, 0.02);
      EXPECT_LT(p95, 0.08);
    }
  }
}

// Interreflection (top of irm.h): samples lit by sun, sky and their neighbours, in the
// photographs' own units (sky radiance a_s, a_t at the horizon, measured in the photographs).
// With both skies known the model's unit is pi a_s: K_t = a_t / a_s and q = 1 / (pi a_s) follow,
// and the suns fitted alone make every sample's ratio exact. Without the indirect term the same
// samples are far off; and samples that carry gathered light the photographs do not show
// (a renderer without interreflection) keep the model without it.
TEST(IrmTest, IndirectLightIsFittedInTheUnitsOfTheSky) {
  const float pi = 3.14159265f;
  const Eigen::Vector3f sun_s = Eigen::Vector3f(0.3f, -0.8f, 0.52f).normalized();
  const Eigen::Vector3f sun_t = Eigen::Vector3f(-0.6f, 0.2f, 0.77f).normalized();
  const Eigen::Vector3f e_sun_s(900, 850, 800), e_sun_t(1000, 980, 950);  // W m^-2
  const Eigen::Vector3f a_s(30, 35, 45), a_t(24, 30, 42);                 // sky radiance, W m^-2 sr^-1
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> state(0, 3);
  std::vector<Sample> samples;
  for (int i = 0; i < 20000; ++i) {
    Sample s;
    s.normal = RandomDirection(rng);
    if (s.normal.z() < -0.5f) continue;
    const int st = state(rng);
    s.source_sun = (st == 0 || st == 2) ? 1.0f : 0.0f;
    s.target_sun = (st == 0 || st == 3) ? 1.0f : 0.0f;
    s.sky_view = 0.5f * (1.0f + s.normal.z()) * (0.5f + 0.5f * unit(rng));
    // What the neighbours send, independently in each photograph (they are lit differently).
    s.source_indirect = Eigen::Vector3f::Constant(150.0f * unit(rng)).cwiseProduct(Eigen::Vector3f(1.0f, 0.9f, 0.8f));
    s.target_indirect = Eigen::Vector3f::Constant(150.0f * unit(rng)).cwiseProduct(Eigen::Vector3f(1.0f, 0.9f, 0.8f));
    const float rho = 0.1f + 0.7f * unit(rng);
    const float cos_s = std::max(0.0f, s.normal.dot(sun_s)), cos_t = std::max(0.0f, s.normal.dot(sun_t));
    s.source_rgb = rho / pi * (e_sun_s * s.source_sun * cos_s + pi * a_s * s.sky_view + s.source_indirect);
    s.target_rgb = rho / pi * (e_sun_t * s.target_sun * cos_t + pi * a_t * s.sky_view + s.target_indirect);
    samples.push_back(s);
  }
  const IrmSet set =
      BuildIrms(samples, sun_s, sun_t, IrmOptions{}, Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero(), a_s, a_t);
  ASSERT_TRUE(set.model.valid) << set.model.reason;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(set.model.indirect_scale[c], 1.0f / (pi * a_s[c]), 1e-6f);
    EXPECT_NEAR(set.model.sky_target[c], a_t[c] / a_s[c], 1e-6f);
    EXPECT_NEAR(set.model.sun_source[c], e_sun_s[c] / (pi * a_s[c]), 1e-3f * e_sun_s[c] / (pi * a_s[c]));
    EXPECT_NEAR(set.model.sun_target[c], e_sun_t[c] / (pi * a_s[c]), 1e-3f * e_sun_t[c] / (pi * a_s[c]));
  }
  EXPECT_LT(set.model.rms_ratio_error, 1e-4);
  EXPECT_GT(set.indirect_share.source_shadow, set.indirect_share.source_lit);
  EXPECT_NE(set.summary.find("indirect light (share"), std::string::npos) << set.summary;
  double worst = 0.0;
  for (int i = 0; i < 500; ++i) {
    const Sample& s = samples[static_cast<std::size_t>(i)];
    const Eigen::Vector3f expected = s.target_rgb.cwiseQuotient(s.source_rgb);
    const Eigen::Vector3f got =
        set.Ratio(s.normal, s.source_sun, s.target_sun, s.sky_view, s.sky_moment, s.source_indirect, s.target_indirect);
    worst = std::max(worst, static_cast<double>((got - expected).cwiseQuotient(expected).cwiseAbs().maxCoeff()));
  }
  EXPECT_LT(worst, 1e-3);

  // Only the source photograph shows its sky: q is still 1 / (pi a_s), K_t is fitted.
  const IrmSet source_only = BuildIrms(samples, sun_s, sun_t, IrmOptions{}, Eigen::Vector3f::Zero(),
                                       Eigen::Vector3f::Zero(), a_s, Eigen::Vector3f::Zero());
  ASSERT_TRUE(source_only.model.valid) << source_only.model.reason;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(source_only.model.indirect_scale[c], 1.0f / (pi * a_s[c]), 1e-6f);
    EXPECT_NEAR(source_only.model.sky_target[c], a_t[c] / a_s[c], 1e-3f);
    EXPECT_NEAR(source_only.model.sun_target[c], e_sun_t[c] / (pi * a_s[c]), 1e-3f * e_sun_t[c] / (pi * a_s[c]));
  }
  EXPECT_LT(source_only.model.rms_ratio_error, 1e-3);

  // Only the target photograph shows its sky: q = K_t / (pi a_t) follows the fitted K_t.
  const IrmSet target_only = BuildIrms(samples, sun_s, sun_t, IrmOptions{}, Eigen::Vector3f::Zero(),
                                       Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero(), a_t);
  ASSERT_TRUE(target_only.model.valid) << target_only.model.reason;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(target_only.model.indirect_scale[c], target_only.model.sky_target[c] / (pi * a_t[c]), 1e-6f);
    EXPECT_NEAR(target_only.model.sky_target[c], a_t[c] / a_s[c], 1e-3f);
    EXPECT_NEAR(target_only.model.indirect_scale[c], 1.0f / (pi * a_s[c]), 1e-3f / (pi * a_s[c]));
  }
  EXPECT_LT(target_only.model.rms_ratio_error, 1e-3);

  // The same photographs read without the neighbours' light: the model cannot hold them.
  std::vector<Sample> blind = samples;
  for (Sample& s : blind) s.source_indirect = s.target_indirect = Eigen::Vector3f::Zero();
  const IrmSet without =
      BuildIrms(blind, sun_s, sun_t, IrmOptions{}, Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero(), a_s, a_t);
  ASSERT_TRUE(without.model.valid);
  EXPECT_GT(without.model.rms_ratio_error, 0.05);

  // Photographs without interreflection, but light gathered from them all the same (a renderer
  // that stops at the first bounce): the indirect term does not explain them, and is left out.
  std::vector<Sample> direct = samples;
  for (Sample& s : direct) {
    const float rho = 0.5f;
    const float cos_s = std::max(0.0f, s.normal.dot(sun_s)), cos_t = std::max(0.0f, s.normal.dot(sun_t));
    s.source_rgb = rho / pi * (e_sun_s * s.source_sun * cos_s + pi * a_s * s.sky_view);
    s.target_rgb = rho / pi * (e_sun_t * s.target_sun * cos_t + pi * a_t * s.sky_view);
  }
  const IrmSet no_bounce =
      BuildIrms(direct, sun_s, sun_t, IrmOptions{}, Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero(), a_s, a_t);
  ASSERT_TRUE(no_bounce.model.valid);
  EXPECT_EQ(no_bounce.model.indirect_scale, Eigen::Vector3f::Zero());
  EXPECT_NE(no_bounce.model.indirect_reason.find("fit better without it"), std::string::npos)
      << no_bounce.model.indirect_reason;
  EXPECT_LT(no_bounce.model.rms_ratio_error, 1e-3);
}

TEST(IrmTest, WhenTheFreeFitFailsTheSkiesMeasureTheSkyRatio) {
  // Three samples: too few for sun, sun and sky ratio (four rows at least), enough for the two
  // suns once both photographs' skies give K_t.
  const float pi = 3.14159265f;
  const Eigen::Vector3f sun_s = Eigen::Vector3f(0.3f, -0.8f, 0.52f).normalized();
  const Eigen::Vector3f sun_t = Eigen::Vector3f(-0.6f, 0.2f, 0.77f).normalized();
  const Eigen::Vector3f e_sun_s(900, 850, 800), e_sun_t(1000, 980, 950);
  const Eigen::Vector3f a_s(30, 35, 45), a_t(24, 30, 42);
  std::vector<Sample> samples;
  for (const auto& [normal, fs, ft] :
       {std::tuple{Eigen::Vector3f(0, 0, 1), 1.0f, 1.0f}, std::tuple{Eigen::Vector3f(0, -1, 0), 1.0f, 0.0f},
        std::tuple{Eigen::Vector3f(-1, 0, 0), 0.0f, 1.0f}}) {
    Sample s;
    s.normal = normal;
    s.source_sun = fs;
    s.target_sun = ft;
    s.sky_view = 0.5f * (1.0f + normal.z());
    const float cos_s = std::max(0.0f, normal.dot(sun_s)), cos_t = std::max(0.0f, normal.dot(sun_t));
    s.source_rgb = 0.4f / pi * (e_sun_s * fs * cos_s + pi * a_s * s.sky_view);
    s.target_rgb = 0.4f / pi * (e_sun_t * ft * cos_t + pi * a_t * s.sky_view);
    samples.push_back(s);
  }
  const IrmSet free_fit = BuildIrms(samples, sun_s, sun_t, IrmOptions{});
  EXPECT_FALSE(free_fit.model.valid);
  const IrmSet set =
      BuildIrms(samples, sun_s, sun_t, IrmOptions{}, Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero(), a_s, a_t);
  ASSERT_TRUE(set.model.valid) << set.model.reason;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(set.model.sky_target[c], a_t[c] / a_s[c], 1e-6f);
    EXPECT_NEAR(set.model.sun_source[c], e_sun_s[c] / (pi * a_s[c]), 1e-3f * e_sun_s[c] / (pi * a_s[c]));
    EXPECT_NEAR(set.model.sun_target[c], e_sun_t[c] / (pi * a_s[c]), 1e-3f * e_sun_t[c] / (pi * a_s[c]));
  }
  EXPECT_NE(set.summary.find("the sky ratio K_t from the photographs' skies"), std::string::npos) << set.summary;
}

TEST(IrmTest, AGradientSkyIsFollowedThroughEachSurfacesZenithMoment) {
  const Truth truth;
  const Eigen::Vector3f g_s(-0.47f, -0.32f, -0.05f), g_t(-0.30f, -0.20f, 0.10f);
  auto irradiance = [&](const Sample& s, bool source) {
    const Eigen::Vector3f& sun = source ? truth.sun_s : truth.sun_t;
    const float a = (source ? s.source_sun : s.target_sun) * std::max(0.0f, s.normal.dot(sun));
    const Eigen::Vector3f g = source ? g_s : g_t;
    const Eigen::Vector3f sky = Eigen::Vector3f::Constant(s.sky_view) + g * s.sky_moment;
    return ((source ? truth.S_s : truth.S_t) * a + (source ? truth.K_s : truth.K_t).cwiseProduct(sky)).eval();
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> state(0, 3);
  std::vector<Sample> samples;
  for (int i = 0; i < 40000; ++i) {
    Sample s;
    s.normal = RandomDirection(rng);
    if (s.normal.z() < -0.3f) continue;
    const int st = state(rng);
    s.source_sun = (st == 0 || st == 2) ? 1.0f : 0.0f;
    s.target_sun = (st == 0 || st == 3) ? 1.0f : 0.0f;
    // Surfaces open to the horizon (m small for their v) and seeing mostly zenith (m near v).
    s.sky_view = 0.3f + 0.7f * unit(rng);
    s.sky_moment = s.sky_view * (0.25f + 0.6f * unit(rng));
    s.source_rgb = 0.4f * irradiance(s, true);
    s.target_rgb = 0.4f * irradiance(s, false);
    samples.push_back(s);
  }
  auto mean_error = [&](const IrmSet& set) {
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < samples.size(); i += 7) {
      const Sample& s = samples[i];
      const Eigen::Vector3f expected = irradiance(s, false).cwiseQuotient(irradiance(s, true));
      const Eigen::Vector3f got = set.Ratio(s.normal, s.source_sun, s.target_sun, s.sky_view, s.sky_moment);
      if (!got.allFinite()) continue;
      sum += (got - expected).cwiseQuotient(expected).cwiseAbs().mean();
      ++n;
    }
    return sum / n;
  };
  const IrmSet shaped = BuildIrms(samples, truth.sun_s, truth.sun_t, IrmOptions{}, g_s, g_t);
  ASSERT_TRUE(shaped.model.valid) << shaped.model.reason;
  EXPECT_LT(shaped.model.rms_relative_residual, 1e-3);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(shaped.model.sky_target[c], truth.K_t[c] / truth.K_s[c], 2e-3f);
  const IrmSet uniform = BuildIrms(samples, truth.sun_s, truth.sun_t, IrmOptions{});
  const double with = mean_error(shaped), without = mean_error(uniform);
  std::printf("gradient sky: mean relative ratio error %.4f with the sky's shape, %.4f without\n", with, without);
  EXPECT_LT(with, 0.01);
  EXPECT_GT(without, 3.0 * with);
  // The same set read without moments takes the sky as uniform (defined, finite).
  EXPECT_TRUE(shaped.Ratio(samples[0].normal, 1.0f, 1.0f, samples[0].sky_view).allFinite());
  // A sky darker than black somewhere is no sky: refused.
  EXPECT_THROW(BuildIrms(samples, truth.sun_s, truth.sun_t, IrmOptions{}, Eigen::Vector3f(-1.0f, 0, 0), g_t),
               InvalidArgumentError);
  EXPECT_THROW(BuildIrms(samples, truth.sun_s, truth.sun_t, IrmOptions{}, g_s, Eigen::Vector3f(NAN, 0, 0)),
               InvalidArgumentError);
}

TEST(IrmTest, OneMapWhenNothingIsInCastShadow) {
  const Truth truth;
  std::mt19937 rng(3);
  const IrmSet set = BuildIrms(MakeSamples(truth, 5000, false, rng), truth.sun_s, truth.sun_t, IrmOptions{});
  EXPECT_TRUE(set.single_map);
  EXPECT_NE(set.summary.find("one IRM"), std::string::npos) << set.summary;
  EXPECT_EQ(set.maps[1].measured_bins(), 0);
}

TEST(IrmTest, OneMapGivesShadowedPixelsTheModelNotTheLitRatio) {
  // The planner skipped the shadow maps (no sample in cast shadow where the photographs
  // overlap), but the source has cast shadows elsewhere: those pixels get the model fitted to
  // the lit samples, which has the sun fractions; the lit map's ratio would be far off.
  const Truth truth;
  std::mt19937 rng(3);
  const IrmSet set = BuildIrms(MakeSamples(truth, 5000, false, rng), truth.sun_s, truth.sun_t, IrmOptions{});
  ASSERT_TRUE(set.single_map);
  ASSERT_TRUE(set.model.valid) << set.model.reason;
  const RatioTable table(set);
  for (const Eigen::Vector3f& n : {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0.6f, 0, 0.8f)}) {
    for (const auto& [fs, ft] :
         {std::pair{0.0f, 1.0f}, std::pair{1.0f, 0.0f}, std::pair{0.0f, 0.0f}, std::pair{0.5f, 1.0f}}) {
      const Eigen::Vector3f want = truth.Ratio(n, fs, ft);
      const Eigen::Vector3f got = set.Ratio(n, fs, ft);
      EXPECT_LT((got - want).cwiseQuotient(want).cwiseAbs().maxCoeff(), 0.02f)
          << n.transpose() << " " << fs << " " << ft;
      EXPECT_LT((table.Ratio(n, fs, ft) - got).norm(), 1e-5f * got.norm());
    }
    // Lit at both times: the map, as before.
    EXPECT_LT((set.Ratio(n, 1.0f, 1.0f) - truth.Ratio(n, 1.0f, 1.0f)).norm(),
              0.02f * truth.Ratio(n, 1.0f, 1.0f).norm());
  }
}

TEST(IrmTest, OneMapWithoutAModelLeavesShadowedPixelsWithoutARatio) {
  // Two normals only: too few for the model. Lit pixels read the map; shadowed ones have no
  // ratio rather than the lit one.
  const Truth truth;
  std::vector<Sample> samples;
  for (const Eigen::Vector3f& n : {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0.6f, 0, 0.8f)}) {
    for (int i = 0; i < 10; ++i) {
      Sample s;
      s.normal = n;
      s.source_rgb = truth.Irradiance(n, 1.0f, true);
      s.target_rgb = truth.Irradiance(n, 1.0f, false);
      samples.push_back(s);
    }
  }
  const IrmSet set = BuildIrms(samples, truth.sun_s, truth.sun_t, IrmOptions{});
  ASSERT_TRUE(set.single_map);
  ASSERT_FALSE(set.model.valid);
  const RatioTable table(set);
  const Eigen::Vector3f n(0, 0, 1);
  EXPECT_LT((set.Ratio(n, 1.0f, 1.0f) - truth.Ratio(n, 1.0f, 1.0f)).norm(), 1e-4f);
  EXPECT_LT((table.Ratio(n, 1.0f, 1.0f) - truth.Ratio(n, 1.0f, 1.0f)).norm(), 1e-4f);
  for (const auto& [fs, ft] : {std::pair{0.0f, 1.0f}, std::pair{1.0f, 0.0f}, std::pair{0.5f, 1.0f}}) {
    EXPECT_FALSE(set.Ratio(n, fs, ft).allFinite()) << fs << " " << ft;
    EXPECT_FALSE(table.Ratio(n, fs, ft).allFinite()) << fs << " " << ft;
  }
}

TEST(IrmTest, FourMapsWhenTheSkipIsTurnedOffAndTheSameRatios) {
  // The planner bench's forced run: all four maps filled, the lit-to-lit ratios unchanged.
  const Truth truth;
  std::mt19937 rng(3);
  const std::vector<Sample> samples = MakeSamples(truth, 5000, false, rng);
  IrmOptions forced;
  forced.single_map_without_shadow = false;
  const IrmSet one = BuildIrms(samples, truth.sun_s, truth.sun_t, IrmOptions{});
  const IrmSet four = BuildIrms(samples, truth.sun_s, truth.sun_t, forced);
  ASSERT_TRUE(one.single_map);
  EXPECT_FALSE(four.single_map);
  EXPECT_NE(four.summary.find("four IRMs"), std::string::npos) << four.summary;
  for (const Eigen::Vector3f& n : {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0.6f, 0, 0.8f)}) {
    const Eigen::Vector3f a = one.Ratio(n, 1.0f, 1.0f), b = four.Ratio(n, 1.0f, 1.0f);
    EXPECT_LT((a - b).norm(), 1e-6f * a.norm()) << n.transpose();
  }
}

TEST(IrmTest, ModelFillExtrapolatesBetterThanSmoothingOnHeldOutNormals) {
  // Samples only from normals with x >= 0: how well does each fill predict the x < 0 half?
  const Truth truth;
  std::mt19937 rng(4);
  const std::vector<Sample> samples = MakeSamples(truth, 20000, false, rng, true);
  IrmOptions model_options;
  model_options.bins = 16;
  IrmOptions smoothing_options = model_options;
  smoothing_options.fill = FillMethod::kSmoothing;
  const IrmSet by_model = BuildIrms(samples, truth.sun_s, truth.sun_t, model_options);
  const IrmSet by_smoothing = BuildIrms(samples, truth.sun_s, truth.sun_t, smoothing_options);
  double model_error = 0.0, smoothing_error = 0.0;
  int count = 0;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3f n = RandomDirection(rng);
    if (n.x() > -0.2f || n.z() < -0.3f) continue;
    const Eigen::Vector3f expected = truth.Ratio(n, 1, 1);
    const Eigen::Vector3f a = by_model.Ratio(n, 1, 1), b = by_smoothing.Ratio(n, 1, 1);
    if (!a.allFinite() || !b.allFinite()) continue;
    model_error += (a - expected).cwiseQuotient(expected).cwiseAbs().mean();
    smoothing_error += (b - expected).cwiseQuotient(expected).cwiseAbs().mean();
    ++count;
  }
  ASSERT_GT(count, 100);
  std::printf("held-out normals: mean relative error, sun+sky model fill %.4f, Gaussian smoothing fill %.4f\n",
              model_error / count, smoothing_error / count);
  EXPECT_LT(model_error, smoothing_error);
}

TEST(IrmTest, DegenerateInputsHaveDefinedOutcomes) {
  // No samples at all.
  const IrmSet empty = BuildIrms({}, {0, 0, 1}, {0, 0, 1}, IrmOptions{});
  EXPECT_FALSE(empty.model.valid);
  EXPECT_FALSE(empty.Ratio({0, 0, 1}, 1, 1).allFinite());  // flagged, not a made-up ratio
  // Black source pixels are skipped, never divided by.
  Sample dark;
  dark.normal = {0, 0, 1};
  dark.source_rgb = Eigen::Vector3f::Zero();
  dark.target_rgb = Eigen::Vector3f::Ones();
  std::vector<Sample> samples(50, dark);
  const IrmSet set = BuildIrms(samples, {0, 0, 1}, {0, 0, 1}, IrmOptions{});
  EXPECT_EQ(set.samples_too_dark, 50);
  EXPECT_EQ(set.samples_used, 0);
  // All normals the same: the model cannot separate sun from sky and says so.
  Sample flat;
  flat.normal = {0, 0, 1};
  flat.source_rgb = Eigen::Vector3f::Constant(0.5f);
  flat.target_rgb = Eigen::Vector3f::Constant(0.6f);
  const IrmSet one_normal = BuildIrms(std::vector<Sample>(100, flat), {0.3f, 0, 0.95f}, {0, 0.3f, 0.95f}, IrmOptions{});
  EXPECT_FALSE(one_normal.model.valid);
  EXPECT_FALSE(one_normal.model.reason.empty());
  EXPECT_NEAR(one_normal.Ratio({0, 0, 1}, 1, 1)[0], 1.2f, 1e-5f);  // the measured bin still works
  IrmOptions bad;
  bad.bins = 1;
  EXPECT_THROW(BuildIrms({}, {0, 0, 1}, {0, 0, 1}, bad), InvalidArgumentError);
}

// RatioTable bakes what IrmSet::Ratio recomputes per lookup; both must give the same ratio up
// to float rounding, for every kind of set: four maps with the model correction, one map,
// smoothing fill, no correction, no valid model, nothing at all.
TEST(IrmTest, RatioTableGivesIrmSetRatio) {
  const Truth truth;
  std::mt19937 rng(5);
  const std::vector<Sample> shadows = MakeSamples(truth, 20000, true, rng);
  const std::vector<Sample> lit = MakeSamples(truth, 5000, false, rng);
  IrmOptions corrected;
  corrected.bins = 16;
  IrmOptions smoothing = corrected;
  smoothing.fill = FillMethod::kSmoothing;
  IrmOptions uncorrected = corrected;
  uncorrected.model_correction = false;
  Sample flat;
  flat.normal = {0, 0, 1};
  flat.source_rgb = Eigen::Vector3f::Constant(0.5f);
  flat.target_rgb = Eigen::Vector3f::Constant(0.6f);
  const std::vector<std::pair<const char*, IrmSet>> sets = {
      {"four maps", BuildIrms(shadows, truth.sun_s, truth.sun_t, corrected)},
      {"one map", BuildIrms(lit, truth.sun_s, truth.sun_t, corrected)},
      {"smoothing", BuildIrms(shadows, truth.sun_s, truth.sun_t, smoothing)},
      {"uncorrected", BuildIrms(shadows, truth.sun_s, truth.sun_t, uncorrected)},
      {"no model", BuildIrms(std::vector<Sample>(100, flat), {0.3f, 0, 0.95f}, {0, 0.3f, 0.95f}, corrected)},
      {"empty", BuildIrms({}, truth.sun_s, truth.sun_t, corrected)}};
  std::vector<Eigen::Vector3f> normals = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0}};
  for (int j = 0; j < 16; ++j) {  // bin centres and bin corners: the interpolation's edges
    for (int i = 0; i < 16; ++i) {
      normals.push_back(DirectionFromOctahedral({(i + 0.5f) / 16, (j + 0.5f) / 16}));
      normals.push_back(DirectionFromOctahedral({i / 16.0f, j / 16.0f}));
    }
  }
  for (int i = 0; i < 3000; ++i) normals.push_back(RandomDirection(rng));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const auto& [name, set] : sets) {
    const RatioTable table(set);
    double worst = 0.0;
    int finite = 0;
    for (const Eigen::Vector3f& n : normals) {
      for (float fs : {0.0f, 0.005f, 0.37f, 0.995f, 1.0f}) {
        for (float ft : {0.0f, 0.81f, 1.0f}) {
          for (float sky : {nan, 0.3f, 1.0f}) {
            const Eigen::Vector3f expected = set.Ratio(n, fs, ft, sky), got = table.Ratio(n, fs, ft, sky);
            ASSERT_EQ(expected.allFinite(), got.allFinite())
                << name << " n " << n.transpose() << " fs " << fs << " ft " << ft << " sky " << sky;
            if (!expected.allFinite()) continue;
            ++finite;
            worst =
                std::max(worst, static_cast<double>((got - expected).cwiseQuotient(expected).cwiseAbs().maxCoeff()));
          }
        }
      }
    }
    std::printf("%s: %d finite ratios, worst relative difference %.2e\n", name, finite, worst);
    EXPECT_LE(worst, 1e-5) << name;
    if (std::string(name) != "empty") {
      EXPECT_GT(finite, 1000) << name;
    }
  }
}

}  // namespace
}  // namespace relume::irm
