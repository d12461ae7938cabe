#include "processing/irm/relight.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "processing/irm/testing_reference.h"
#include "processing/irm/testing_scene.h"

namespace relume::irm {
namespace {

using testing::Light;
using testing::OutdoorScene;

struct Errors {
  double lit = 0, shadow = 0, penumbra = 0;
  int n_lit = 0, n_shadow = 0, n_penumbra = 0;
  void Add(double e2, float fs, float ft) {
    const bool pure_s = fs <= 0.0f || fs >= 1.0f, pure_t = ft <= 0.0f || ft >= 1.0f;
    if (!pure_s || !pure_t) {
      penumbra += e2;
      ++n_penumbra;
    } else if (fs >= 1.0f && ft >= 1.0f) {
      lit += e2;
      ++n_lit;
    } else {
      shadow += e2;
      ++n_shadow;
    }
  }
  double Rms(double sum, int n) const { return n ? std::sqrt(sum / n) : 0.0; }
};

struct RegionRms {
  double lit = 0.0, shadow = 0.0;
};

class RelightTest : public ::testing::Test {
 protected:
  RegionRms Run(int render_sky_samples, int method_sky_samples, bool check_untouched);
  RelightTest() : scene_(16), caster_(scene_.mesh) {
    const PinholeIntrinsics k = PinholeIntrinsics::FromHorizontalFov(200, 140, 1.1);
    source_camera_ = PinholeCamera::LookAt(k, {-14, -30, 10}, {2, 0, 5});
    target_camera_ = PinholeCamera::LookAt(k, {10, -32, 12}, {0, 0, 4});
    // Morning sun from the east (the neighbour shadows the building), afternoon from the
    // south-west; different sky colour too.
    source_light_ = {testing::SunFromAzimuthElevationDeg(95, 25), {900, 850, 780}, {28, 33, 45}};
    target_light_ = {testing::SunFromAzimuthElevationDeg(230, 50), {1000, 980, 950}, {20, 26, 40}};
  }
  OutdoorScene scene_;
  RayCaster caster_;
  PinholeCamera source_camera_, target_camera_;
  Light source_light_, target_light_;
};

// Relights the source to the target's light and compares it with the source camera's render
// under the target light, per region. `render_sky_samples` > 0: the renderer's sky is occluded
// by the scene; `method_sky_samples`: RelightOptions::sky_samples.
RegionRms RelightTest::Run(int render_sky_samples, int method_sky_samples, bool check_untouched) {
  cv::Mat truth_fs, truth_ft;
  const int n = render_sky_samples;
  const RadianceImage source = testing::Render(caster_, source_camera_, source_light_, &truth_fs, 32, n);
  const RadianceImage target = testing::Render(caster_, target_camera_, target_light_, nullptr, 32, n);
  // What the source camera would have seen under the target light: the truth to match.
  const RadianceImage truth = testing::Render(caster_, source_camera_, target_light_, &truth_ft, 32, n);

  RelightOptions options;
  options.irm.bins = 24;
  options.sky_samples = method_sky_samples;
  const RelightResult result = RelightImage(caster_, {&source, source_camera_, source_light_.sun_dir, {}},
                                            {&target, target_camera_, target_light_.sun_dir, {}}, options);
  EXPECT_FALSE(result.irms.single_map);
  EXPECT_GT(result.summary.visible_in_both, 1000);
  EXPECT_LT(result.summary.overlap_rms_after, 0.25 * result.summary.overlap_rms_before);
  Errors relit, baseline;
  for (int y = 0; y < source.height(); ++y) {
    for (int x = 0; x < source.width(); ++x) {
      if (result.status.at<std::uint8_t>(y, x) != kRelit) continue;
      const cv::Vec3f t = truth.pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f r = result.relit.pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f s = source.pixels.at<cv::Vec3f>(y, x);
      double e_relit = 0, e_base = 0;
      for (int c = 0; c < 3; ++c) {
        e_relit += std::pow((r[c] - t[c]) / t[c], 2) / 3;
        e_base += std::pow((s[c] - t[c]) / t[c], 2) / 3;
      }
      relit.Add(e_relit, truth_fs.at<float>(y, x), truth_ft.at<float>(y, x));
      baseline.Add(e_base, truth_fs.at<float>(y, x), truth_ft.at<float>(y, x));
    }
  }
  std::printf(
      "IRM relighting, relative RMS (relit | no relighting): lit %.4f | %.4f (%d px), "
      "shadow %.4f | %.4f (%d px), penumbra %.4f | %.4f (%d px)\n  %s\n",
      relit.Rms(relit.lit, relit.n_lit), baseline.Rms(baseline.lit, baseline.n_lit), relit.n_lit,
      relit.Rms(relit.shadow, relit.n_shadow), baseline.Rms(baseline.shadow, baseline.n_shadow), relit.n_shadow,
      relit.Rms(relit.penumbra, relit.n_penumbra), baseline.Rms(baseline.penumbra, baseline.n_penumbra),
      relit.n_penumbra, result.summary.irm_summary.c_str());
  EXPECT_GT(relit.n_lit, 1000);
  EXPECT_GT(relit.n_shadow, 200);
  EXPECT_LT(relit.Rms(relit.penumbra, relit.n_penumbra), baseline.Rms(baseline.penumbra, baseline.n_penumbra));
  // Sky pixels are untouched and flagged.
  EXPECT_GT(result.summary.pixels_without_geometry, 0);
  for (int y = 0; check_untouched && y < source.height(); ++y) {
    for (int x = 0; x < source.width(); ++x) {
      if (result.status.at<std::uint8_t>(y, x) == kNoGeometry) {
        EXPECT_EQ(result.relit.pixels.at<cv::Vec3f>(y, x), source.pixels.at<cv::Vec3f>(y, x));
      }
    }
  }
  return {relit.Rms(relit.lit, relit.n_lit), relit.Rms(relit.shadow, relit.n_shadow)};
}

TEST_F(RelightTest, RelitSourceMatchesTheTargetLight) {
  // The paper's sky (unoccluded), and the method told so (no sky view).
  const RegionRms rms = Run(/*render_sky_samples=*/0, /*method_sky_samples=*/0, /*check_untouched=*/true);
  EXPECT_LT(rms.lit, 0.02);
  EXPECT_LT(rms.shadow, 0.02);
}

TEST_F(RelightTest, AnOccludedSkyIsFollowedThroughEachSurfacesSkyView) {
  // The sky occluded by the buildings, as outdoors: a surface in cast shadow is lit by the sky
  // it sees, which differs from place to place for one normal. With the per-vertex sky view the
  // 2% goal holds; without it (every surface open to the sky), the shadows miss it.
  const RegionRms with = Run(/*render_sky_samples=*/400, RelightOptions().sky_samples, false);
  const RegionRms without = Run(400, 0, false);
  std::printf("occluded sky: shadow %.4f with sky view, %.4f without\n", with.shadow, without.shadow);
  EXPECT_LT(with.lit, 0.02);
  EXPECT_LT(with.shadow, 0.02);
  EXPECT_GT(without.shadow, 2.0 * with.shadow);
}

// RelightPixels against the plain per-pixel definition (testing_reference.h) on the analytic
// scene: the same status and sun fractions everywhere, the same relit radiance up to float
// rounding, with and without sky views, penumbra fractions, exact shadow edges, a mask, and
// vertices without fractions or sky views (the pixels' own rays).
TEST_F(RelightTest, RelightPixelsMatchesItsDefinitionPerPixel) {
  const RadianceImage source = testing::Render(caster_, source_camera_, source_light_);
  const RadianceImage target = testing::Render(caster_, target_camera_, target_light_);
  cv::Mat mask(source.height(), source.width(), CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(90, 60, 20, 15)).setTo(1);
  struct Case {
    int sky_samples;
    bool penumbra, exact_shadow_edges, vertices_without_values;
  };
  for (const Case& k : {Case{144, true, true, false}, Case{0, true, true, false}, Case{144, false, true, false},
                        Case{144, true, false, false}, Case{144, true, true, true}, Case{0, false, false, true}}) {
    RelightOptions options;
    options.irm.bins = 24;
    options.sky_samples = k.sky_samples;
    options.use_penumbra_fractions = k.penumbra;
    options.exact_shadow_edges = k.exact_shadow_edges;
    const View s{&source, source_camera_, source_light_.sun_dir, mask};
    const View t{&target, target_camera_, target_light_.sun_dir, {}};
    ViewGeometry gs = ComputeViewGeometry(caster_, s, options);
    ViewGeometry gt = ComputeViewGeometry(caster_, t, options, /*with_sky_view=*/false);
    RelightSummary summary;
    const IrmSet irms = BuildIrmsFromViews(caster_, s, t, gs, gt, options, &summary);
    if (k.vertices_without_values) {
      for (std::size_t i = 0; i < gs.sun_fraction.size(); i += 7) gs.sun_fraction[i] = NAN;
      for (std::size_t i = 0; i < gs.sky_view.size(); i += 5) gs.sky_view[i] = NAN;
      for (std::size_t i = 3; i < gt.sun_fraction.size(); i += 11) gt.sun_fraction[i] = NAN;
    }
    const RelightResult fast = RelightPixels(caster_, s, t, gs, gt, irms, options, summary);
    const RelightResult plain = testing::RelightPixelsByDefinition(caster_, s, t, gs, gt, irms, options);
    const testing::RelightDifference d = testing::CompareRelightings(fast, plain);
    const std::string name = "sky " + std::to_string(k.sky_samples) + " penumbra " + std::to_string(k.penumbra) +
                             " exact " + std::to_string(k.exact_shadow_edges) + " holes " +
                             std::to_string(k.vertices_without_values);
    std::printf("%s: %lld relit, %lld with own sun rays, %lld with own sky rays; largest relative difference %.2e\n",
                name.c_str(), static_cast<long long>(fast.summary.pixels_relit),
                static_cast<long long>(fast.summary.pixels_with_own_sun_rays),
                static_cast<long long>(fast.summary.pixels_with_own_sky_rays), d.max_relative);
    EXPECT_EQ(d.status_differs, 0) << name;
    EXPECT_EQ(d.fraction_differs, 0) << name;
    EXPECT_LE(d.max_relative, 1e-5) << name;
    EXPECT_GT(fast.summary.pixels_relit, 10000) << name;
    std::int64_t masked = 0;  // mask pixels with geometry
    for (int y = 0; y < mask.rows; ++y) {
      for (int x = 0; x < mask.cols; ++x) masked += mask.at<std::uint8_t>(y, x) && plain.status.at<std::uint8_t>(y, x);
    }
    EXPECT_EQ(fast.summary.pixels_masked, masked) << name;
    EXPECT_GT(masked, 0) << name;
    if (k.exact_shadow_edges || k.vertices_without_values) {
      EXPECT_GT(fast.summary.pixels_with_own_sun_rays, 100) << name;
    }
    // Own sky rays: vertices without a sky view, or (exact_shadow_edges) triangles whose
    // vertices' sky views differ, as the ground's along the buildings' feet.
    EXPECT_EQ(fast.summary.pixels_with_own_sky_rays > 0,
              (k.vertices_without_values || k.exact_shadow_edges) && k.sky_samples > 0)
        << name;
    // Per-worker caches must not make a pixel depend on which worker relit it.
    RelightOptions other_threads = options;
    other_threads.threads = options.threads == 1 ? 3 : 1;
    const testing::RelightDifference threads =
        testing::CompareRelightings(RelightPixels(caster_, s, t, gs, gt, irms, other_threads, summary), fast);
    EXPECT_EQ(threads.status_differs, 0) << name;
    EXPECT_EQ(threads.fraction_differs, 0) << name;
    EXPECT_EQ(threads.max_relative, 0.0) << name;
  }
}

TEST_F(RelightTest, NoCastShadowMeansOneMap) {
  // High sun from the south: the neighbour's shadow falls north of it, away from the building
  // and out of both views... use a scene without the neighbour to be sure.
  TriangleMesh lone;
  lone.Append(MakeQuad({-30, -30, 0}, {60, 0, 0}, {0, 60, 0}, 20));
  lone.Append(MakeBox({-6, -3, 0}, {6, 3, 8}, 8));
  lone.albedo.assign(lone.vertex_count(), Eigen::Vector3f(0.4f, 0.4f, 0.4f));
  const RayCaster caster(lone);
  // Both suns high enough and from the south so that the building's own shadow falls behind it.
  const Light a{testing::SunFromAzimuthElevationDeg(170, 70), {900, 900, 900}, {30, 30, 40}};
  const Light b{testing::SunFromAzimuthElevationDeg(190, 75), {1000, 1000, 1000}, {25, 25, 35}};
  const PinholeCamera camera =
      PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(80, 60, 1.0), {0, -30, 6}, {0, 0, 4});
  const RadianceImage source = testing::Render(caster, camera, a);
  const RadianceImage target = testing::Render(caster, camera, b);
  const RelightResult result =
      RelightImage(caster, {&source, camera, a.sun_dir, {}}, {&target, camera, b.sun_dir, {}}, RelightOptions{});
  EXPECT_TRUE(result.irms.single_map) << result.summary.irm_summary;
}

TEST_F(RelightTest, RejectsInconsistentInputs) {
  const RadianceImage small = MakeRadianceImage(10, 10);
  RelightOptions options;
  EXPECT_THROW(RelightImage(caster_, {&small, source_camera_, source_light_.sun_dir, {}},
                            {&small, target_camera_, target_light_.sun_dir, {}}, options),
               InvalidArgumentError);
  options.sun_samples = 0;
  EXPECT_THROW(RelightImage(caster_, {&small, source_camera_, source_light_.sun_dir, {}},
                            {&small, target_camera_, target_light_.sun_dir, {}}, options),
               InvalidArgumentError);
}

}  // namespace
}  // namespace relume::irm
