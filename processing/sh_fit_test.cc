#include "processing/sh_fit.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <opencv2/core.hpp>
#include <random>

#include "core/error.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::processing {
namespace {

ShRgb SkyLight() {
  return ProjectEnvironmentMap(testing::MakeSkySunMap(64, 32, {}), testing::CameraFromMap());
}

// Every object pixel of an ideal frame, with true normals, true albedo and object labels.
std::vector<ShObservation> IdealObservations(const testing::SyntheticFrame& frame) {
  std::vector<cv::Point> points;
  cv::findNonZero(frame.object_mask, points);
  return GatherObservations(frame.radiance, frame.normal_in_camera, frame.albedo, frame.object_id, points);
}

// Observations on a sphere cap: normals within cap_rad of the direction facing the camera.
std::vector<ShObservation> CapObservations(const ShRgb& light, double cap_rad, int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<ShObservation> out;
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - uniform(rng) * (1.0 - std::cos(cap_rad));  // uniform on the cap
    const double phi = 2.0 * std::numbers::pi * uniform(rng);
    const double s = std::sqrt(1.0 - z * z);
    ShObservation o;
    o.normal = Eigen::Vector3d(s * std::cos(phi), s * std::sin(phi), -z);
    o.albedo = Eigen::Vector3d(0.5, 0.6, 0.7);
    o.radiance = o.albedo.cwiseProduct(ShIrradiance(light, o.normal)) / std::numbers::pi;
    out.push_back(o);
  }
  return out;
}

TEST(ShFitTest, KnownAlbedoRecoversTheLightFromIdealData) {
  const ShRgb light = SkyLight();
  const testing::SyntheticFrame frame = testing::RenderScene({}, light);
  const ShFitResult fit = FitShKnownAlbedo(IdealObservations(frame));
  ASSERT_TRUE(fit.summary.usable) << fit.summary.BriefReport();
  EXPECT_EQ(fit.summary.order_used, 2);
  EXPECT_FALSE(fit.summary.order_reduced);
  EXPECT_LT((fit.light - light).norm(), 1e-4 * light.norm()) << fit.light - light;
  EXPECT_LT(fit.summary.relative_rms_residual, 1e-5);
  EXPECT_GT(fit.summary.normal_solid_angle_sr, 4.0);  // the visible hemisphere, about 2 pi
  EXPECT_LT(fit.summary.normal_solid_angle_sr, 6.5);
}

// The normals' coverage decides the order: a table of condition numbers against cap size
// (printed for docs/processing-sh.md) and the fallback at the default thresholds.
TEST(ShFitTest, ConditionNumberGrowsAsTheNormalsNarrow) {
  const ShRgb light = SkyLight();
  double previous = 0.0;
  for (double cap_deg : {90.0, 75.0, 60.0, 45.0, 30.0, 15.0}) {
    const auto observations = CapObservations(light, cap_deg * std::numbers::pi / 180.0, 3000, 5);
    const double c2 = ShConditionNumber(observations, 2), c1 = ShConditionNumber(observations, 1);
    const ShFitResult fit = FitShKnownAlbedo(observations);
    std::printf("cap %4.0f deg: solid angle %.2f sr, condition order 2 %.1f, order 1 %.1f -> order %d\n", cap_deg,
                NormalSolidAngleSr(observations), c2, c1, fit.summary.order_used);
    EXPECT_GT(c2, previous);
    previous = c2;
    ASSERT_TRUE(fit.summary.usable);
    // Whatever order is used, the irradiance is right on the normals that were seen.
    double error = 0.0, total = 0.0;
    for (const ShObservation& o : observations) {
      error += (ShIrradiance(fit.light, o.normal) - ShIrradiance(light, o.normal)).squaredNorm();
      total += ShIrradiance(light, o.normal).squaredNorm();
    }
    if (fit.summary.order_used == 2) {
      EXPECT_LT(std::sqrt(error / total), 1e-6) << cap_deg;
    }
  }
  const ShFitResult hemisphere = FitShKnownAlbedo(CapObservations(light, std::numbers::pi / 2, 3000, 5));
  EXPECT_EQ(hemisphere.summary.order_used, 2);
  const ShFitResult narrow = FitShKnownAlbedo(CapObservations(light, 15.0 * std::numbers::pi / 180.0, 3000, 5));
  EXPECT_LT(narrow.summary.order_used, 2);
  EXPECT_TRUE(narrow.summary.order_reduced);
  EXPECT_NE(narrow.summary.message.find("order 2 not supported"), std::string::npos) << narrow.summary.message;
}

TEST(ShFitTest, PlaneGivesOrderZeroWithAReason) {
  const ShRgb light = SkyLight();
  std::vector<ShObservation> observations = CapObservations(light, 0.0, 200, 1);  // all n = (0, 0, -1)
  const ShFitResult fit = FitShKnownAlbedo(observations);
  ASSERT_TRUE(fit.summary.usable);
  EXPECT_EQ(fit.summary.order_used, 0);
  EXPECT_TRUE(fit.light.bottomRows(8).isZero());
  // Order 0 still reproduces the one irradiance that was observed.
  const Eigen::Vector3d n(0, 0, -1);
  EXPECT_LT((ShIrradiance(fit.light, n) - ShIrradiance(light, n)).norm(), 1e-6 * ShIrradiance(light, n).norm());
  EXPECT_TRUE(fit.light.allFinite());
}

TEST(ShFitTest, NoObservationsIsNotUsableAndHasNoNan) {
  const ShFitResult fit = FitShKnownAlbedo({});
  EXPECT_FALSE(fit.summary.usable);
  EXPECT_TRUE(fit.light.isZero());
  EXPECT_FALSE(fit.summary.message.empty());
  const ShAlbedoFitResult unknown = FitShUnknownAlbedo({});
  EXPECT_FALSE(unknown.summary.usable);
  EXPECT_TRUE(unknown.light.isZero());
}

TEST(ShFitTest, ZeroAlbedoGivesNoNan) {
  std::vector<ShObservation> observations = CapObservations(SkyLight(), std::numbers::pi / 2, 500, 2);
  for (ShObservation& o : observations) o.albedo.setZero();
  const ShFitResult fit = FitShKnownAlbedo(observations);
  EXPECT_TRUE(fit.light.allFinite());
  if (fit.summary.usable) {
    EXPECT_TRUE(fit.light.isZero());
  } else {
    EXPECT_FALSE(fit.summary.message.empty());
  }
}

TEST(ShFitTest, UnknownAlbedoWithTheReferenceGivenRecoversEverything) {
  const ShRgb light = SkyLight();
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, light);
  ShAlbedoFitOptions options;
  options.reference_segment = testing::kBigSphere;
  options.reference_albedo = scene.big_sphere_albedo;
  const ShAlbedoFitResult fit = FitShUnknownAlbedo(IdealObservations(frame), options);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.BriefReport();
  EXPECT_TRUE(fit.summary.converged) << fit.summary.BriefReport();
  std::printf("unknown albedo, ideal data: %s\n", fit.summary.BriefReport().c_str());
  EXPECT_LT((fit.light - light).norm(), 1e-4 * light.norm());
  EXPECT_LT((fit.segment_albedo[testing::kSmallSphere] - scene.small_sphere_albedo).norm(), 1e-4);
  EXPECT_LT((fit.segment_albedo[testing::kBox] - scene.box_albedo).norm(), 1e-4);
}

TEST(ShFitTest, UnknownAlbedoDefaultReferenceIsRightUpToOneScalePerChannel) {
  const ShRgb light = SkyLight();
  const testing::SceneOptions scene;
  const testing::SyntheticFrame frame = testing::RenderScene(scene, light);
  const ShAlbedoFitResult fit = FitShUnknownAlbedo(IdealObservations(frame));
  ASSERT_TRUE(fit.summary.converged) << fit.summary.BriefReport();
  EXPECT_EQ(fit.reference_segment, testing::kBigSphere);  // the largest
  EXPECT_NE(fit.summary.message.find("scale fixed by segment 0"), std::string::npos);
  EXPECT_LT((fit.segment_albedo[0] - Eigen::Vector3d::Constant(0.5)).norm(), 1e-12);
  for (int c = 0; c < 3; ++c) {
    const double scale = 0.5 / scene.big_sphere_albedo(c);  // albedo scale; light scales by its inverse
    EXPECT_LT((fit.light.col(c) * scale - light.col(c)).norm(), 1e-4 * light.col(c).norm()) << c;
    EXPECT_NEAR(fit.segment_albedo[testing::kBox](c), scene.box_albedo(c) * scale, 1e-4) << c;
  }
}

TEST(ShFitTest, UnknownAlbedoWithABlackReferenceIsNotUsable) {
  std::vector<ShObservation> observations = CapObservations(SkyLight(), std::numbers::pi / 2, 200, 2);
  for (ShObservation& o : observations) o.radiance.setZero();
  const ShAlbedoFitResult fit = FitShUnknownAlbedo(observations);
  EXPECT_FALSE(fit.summary.usable);
  EXPECT_TRUE(fit.light.allFinite());
  EXPECT_NE(fit.summary.message.find("black"), std::string::npos) << fit.summary.message;
}

// Flat facets of a box seen from a corner (five orientations, normals jittered by ~0.01 rad as
// estimated normals are), lit by the sky-and-sun light; facet f gets label labels[f].
std::vector<ShObservation> FacetObservations(const std::array<int, 5>& labels) {
  const ShRgb light = SkyLight();
  const std::array<Eigen::Vector3d, 5> facets = {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(-1, 0, -1),
                                                 Eigen::Vector3d(1, 0, -1), Eigen::Vector3d(0, -1, -1),
                                                 Eigen::Vector3d(0, 1, -1)};
  std::mt19937_64 rng(5);
  std::normal_distribution<double> jitter(0.0, 0.01);
  std::vector<ShObservation> out;
  for (std::size_t f = 0; f < facets.size(); ++f) {
    for (int i = 0; i < 400; ++i) {
      ShObservation o;
      o.normal = (facets[f].normalized() + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng))).normalized();
      o.segment = labels[f];
      const Eigen::Vector3d albedo = Eigen::Vector3d(0.3, 0.4, 0.5) * (1.0 + 0.2 * labels[f]);
      o.radiance = albedo.cwiseProduct(ShIrradiance(light, o.normal)) / std::numbers::pi;
      out.push_back(o);
    }
  }
  return out;
}

TEST(ShFitTest, UnknownAlbedoSaysWhetherThePixelsTellTheLightFromTheAlbedos) {
  ShAlbedoFitOptions options;
  options.fit.max_order = 1;  // five orientations support order 1 only
  // One material on every facet: its albedo is one unknown, the five orientations fix the light.
  const ShAlbedoFitResult one = FitShUnknownAlbedo(FacetObservations({0, 0, 0, 0, 0}), options);
  ASSERT_TRUE(one.summary.usable) << one.summary.BriefReport();
  EXPECT_LT(one.summary.albedo_light_condition_number, 100.0) << one.summary.BriefReport();
  // A material per facet: each facet's albedo absorbs whatever irradiance its one orientation
  // receives; only the normals' jitter within a facet says anything about the light. Measured:
  // 393 against 13 for one material (and the alternation does not converge in 200 iterations).
  const ShAlbedoFitResult each = FitShUnknownAlbedo(FacetObservations({0, 1, 2, 3, 4}), options);
  ASSERT_TRUE(each.summary.usable) << each.summary.BriefReport();
  EXPECT_GT(each.summary.albedo_light_condition_number, 10.0 * one.summary.albedo_light_condition_number)
      << each.summary.BriefReport();
  // Smooth surfaces with a material each (the synthetic objects): well determined.
  const testing::SyntheticFrame frame = testing::RenderScene({}, SkyLight());
  std::vector<ShObservation> curved = IdealObservations(frame);
  const ShAlbedoFitResult objects = FitShUnknownAlbedo(curved);
  ASSERT_TRUE(objects.summary.usable) << objects.summary.BriefReport();
  EXPECT_LT(objects.summary.albedo_light_condition_number, 100.0) << objects.summary.BriefReport();
  // Known albedo: not applicable.
  EXPECT_TRUE(std::isnan(FitShKnownAlbedo(curved).summary.albedo_light_condition_number));
  std::printf("albedo-light condition: one material %.3g, a material per facet %.3g, objects %.3g\n",
              one.summary.albedo_light_condition_number, each.summary.albedo_light_condition_number,
              objects.summary.albedo_light_condition_number);
}

TEST(ShFitTest, InvalidOptionsThrow) {
  ShFitOptions options;
  options.max_order = 3;
  EXPECT_THROW(FitShKnownAlbedo({}, options), InvalidArgumentError);
  ShAlbedoFitOptions albedo_options;
  albedo_options.reference_albedo = Eigen::Vector3d(0.5, 0.0, 0.5);
  EXPECT_THROW(FitShUnknownAlbedo({}, albedo_options), InvalidArgumentError);
  ShObservation unlabelled;
  unlabelled.normal = Eigen::Vector3d::UnitZ();
  unlabelled.radiance = Eigen::Vector3d::Ones();
  unlabelled.segment = -1;
  EXPECT_THROW(FitShUnknownAlbedo({unlabelled}), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::processing
