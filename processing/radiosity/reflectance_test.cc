#include "processing/radiosity/reflectance.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>

#include "core/error.h"
#include "processing/radiosity/blocks.h"
#include "processing/radiosity/test_room.h"

namespace relume::radiosity {
namespace {

constexpr double kPatchEdgeM = 0.6;

// One furnished room with six lamp positions, rendered once for every test here.
class RoomTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    room_ = std::make_unique<testing::TestRoom>(testing::MakeTestRoom(6));
    HierarchyOptions options;
    options.max_patch_edge_m = kPatchEdgeM;
    hierarchy_ = std::make_unique<PatchHierarchy>(room_->mesh, options);
    caster_ = std::make_unique<RayCaster>(room_->mesh.geometry);
    photos_ =
        std::make_unique<std::vector<RadianceObservation>>(testing::RenderPhotographs(*room_, *hierarchy_, *caster_));
  }
  static void TearDownTestSuite() {
    photos_.reset();
    caster_.reset();
    hierarchy_.reset();
    room_.reset();
  }
  static void Print(const char* label, const ReflectanceResult& r) {
    const auto before = testing::CompareAlbedo(*hierarchy_, r.initial_albedo, r.estimated);
    const auto after = testing::CompareAlbedo(*hierarchy_, r.albedo, r.estimated);
    std::printf("%s: %d patches, %d iterations, %s; %s\n", label, hierarchy_->LeafCount(), r.iterations,
                r.converged ? "converged" : "not converged", r.reason.c_str());
    for (size_t i = 0; i < r.max_change.size(); ++i) {
      std::printf("  iteration %zu: max change %.5f, mean change %.6f\n", i + 1, r.max_change[i], r.mean_change[i]);
    }
    for (size_t m = 0; m < after.size(); ++m) {
      std::printf("  %-8s n=%4d  before: err %.4f sd %.4f range %.4f  after: err %.4f sd %.4f range %.4f\n",
                  room_->mesh.materials[m].name.c_str(), after[m].patches, before[m].mean_abs_error, before[m].spread,
                  before[m].range, after[m].mean_abs_error, after[m].spread, after[m].range);
    }
  }
  static std::unique_ptr<testing::TestRoom> room_;
  static std::unique_ptr<PatchHierarchy> hierarchy_;
  static std::unique_ptr<RayCaster> caster_;
  static std::unique_ptr<std::vector<RadianceObservation>> photos_;
};
std::unique_ptr<testing::TestRoom> RoomTest::room_;
std::unique_ptr<PatchHierarchy> RoomTest::hierarchy_;
std::unique_ptr<RayCaster> RoomTest::caster_;
std::unique_ptr<std::vector<RadianceObservation>> RoomTest::photos_;

TEST_F(RoomTest, NoiseFreeAlbedoWithinOnePercentInFourIterations) {
  const ReflectanceResult r = EstimateReflectance(*hierarchy_, *caster_, *photos_, {});
  Print("noise-free", r);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LE(r.iterations, 4);
  const auto before = testing::CompareAlbedo(*hierarchy_, r.initial_albedo, r.estimated);
  const auto after = testing::CompareAlbedo(*hierarchy_, r.albedo, r.estimated);
  double mean_before = 0.0, mean_after = 0.0;
  for (size_t m = 0; m < after.size(); ++m) {
    ASSERT_GT(after[m].patches, 10) << room_->mesh.materials[m].name;
    EXPECT_LE(after[m].mean_abs_error, 0.01) << room_->mesh.materials[m].name;
    EXPECT_LE(after[m].spread, 0.02) << room_->mesh.materials[m].name;
    mean_before += before[m].mean_abs_error / after.size();
    mean_after += after[m].mean_abs_error / after.size();
  }
  EXPECT_LT(mean_after, 0.25 * mean_before);  // the iterations are what makes it accurate
  // The ceiling (albedo 0.9) is the near-white case.
  EXPECT_LE(after[room_->ceiling].mean_abs_error, 0.01);
}

TEST_F(RoomTest, EvOnlyCameraScalesAreRecovered) {
  std::vector<RadianceObservation> photos = *photos_;
  const std::vector<double> scales = {1.0, 0.5, 2.0, 1.3, 0.8, 3.1};
  testing::ApplyImageScales(scales, &photos);
  ReflectanceOptions options;
  options.fit_image_scales = true;
  const ReflectanceResult r = EstimateReflectance(*hierarchy_, *caster_, photos, options);
  Print("EV-only scales", r);
  for (size_t s = 1; s < scales.size(); ++s) {
    EXPECT_GT(r.scale_samples[s], 20);
    EXPECT_NEAR(r.image_scale[s] * scales[s], 1.0, 0.03) << "image " << s;
  }
  for (const auto& e : testing::CompareAlbedo(*hierarchy_, r.albedo, r.estimated)) EXPECT_LE(e.mean_abs_error, 0.015);
}

TEST_F(RoomTest, CameraNoiseFigures) {
  for (double sigma : {0.05}) {
    std::vector<RadianceObservation> photos = *photos_;
    testing::AddCameraNoise(sigma, 7, &photos);
    const ReflectanceResult r = EstimateReflectance(*hierarchy_, *caster_, photos, {});
    char label[64];
    std::snprintf(label, sizeof(label), "camera noise %.0f%%", 100 * sigma);
    Print(label, r);
    for (const auto& e : testing::CompareAlbedo(*hierarchy_, r.albedo, r.estimated)) {
      // Weighted averaging over six images shrinks per-patch noise by about sqrt(6).
      EXPECT_LE(e.mean_abs_error, 0.01 + sigma * 0.5);
    }
  }
}

TEST_F(RoomTest, LoscosIndirectFromSimulationIsReported) {
  ReflectanceOptions options;
  options.indirect_from_observed = false;
  options.max_iterations = 4;
  const ReflectanceResult r = EstimateReflectance(*hierarchy_, *caster_, *photos_, options);
  Print("indirect from simulation only (Loscos)", r);
  // In this room indirect light outweighs direct: the plain fixed point does not settle, and
  // the result says so instead of claiming convergence.
  EXPECT_FALSE(r.converged);
  for (const Rgb& a : r.albedo) EXPECT_TRUE(a.allFinite());
}

TEST_F(RoomTest, BlocksCostLittleErrorAgainstFullResolution) {
  BlockOptions blocks;
  blocks.block_size_m = 2.0;
  blocks.fine_edge_m = kPatchEdgeM;
  blocks.medium_edge_m = 2 * kPatchEdgeM;
  blocks.coarse_edge_m = 4 * kPatchEdgeM;
  const ReflectanceResult full = EstimateReflectance(*hierarchy_, *caster_, *photos_, {});
  const BlockResult b = EstimateReflectanceInBlocks(*hierarchy_, *caster_, *photos_, blocks, {});
  const auto err_full = testing::CompareAlbedo(*hierarchy_, full.albedo, full.estimated);
  const auto err_blocks = testing::CompareAlbedo(*hierarchy_, b.albedo, b.estimated);
  std::printf(
      "blocks: %d blocks, max %d / mean %.0f patches per block (full %d), max links %lld, %.2f s (full %.2f s)\n",
      b.blocks, b.max_block_patches, b.mean_block_patches, hierarchy_->LeafCount(), b.max_block_links, b.time_s,
      full.time_s);
  for (size_t m = 0; m < err_full.size(); ++m) {
    std::printf("  %-8s full err %.4f sd %.4f   blocks err %.4f sd %.4f\n", room_->mesh.materials[m].name.c_str(),
                err_full[m].mean_abs_error, err_full[m].spread, err_blocks[m].mean_abs_error, err_blocks[m].spread);
    EXPECT_LE(err_blocks[m].mean_abs_error, err_full[m].mean_abs_error + 0.02);
  }
  EXPECT_GT(b.blocks, 1);
  EXPECT_LT(b.max_block_patches, hierarchy_->LeafCount());
}

TEST(ReflectanceTest, OpenGroundSkipsRadiosityAndIsExact) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"asphalt", Rgb(0.12, 0.11, 0.10), Rgb::Zero()});
  mesh.AddQuad({-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}, m);
  HierarchyOptions ho;
  ho.max_patch_edge_m = 2.0;
  const PatchHierarchy h(mesh, ho);
  const RayCaster caster(mesh.geometry);
  RadianceObservation obs;
  obs.lighting.sun_sky.push_back({Eigen::Vector3d(0.0, 0.6, 0.8), Rgb::Constant(1000.0), Rgb::Constant(30.0)});
  const DirectLight direct = ComputeDirectLight(h, caster, obs.lighting, {});
  for (int p = 0; p < h.LeafCount(); ++p) {
    obs.radiance.push_back(h.LeafAlbedo()[p].cwiseProduct(direct.irradiance[p]) / std::numbers::pi);
  }
  ReflectanceOptions options;
  options.indirect_skip_tolerance = 0.01;
  const ReflectanceResult r = EstimateReflectance(h, caster, {obs}, options);
  EXPECT_TRUE(r.radiosity_skipped) << r.reason;
  EXPECT_NE(r.reason.find("skipped"), std::string::npos);
  for (const Rgb& a : r.albedo) EXPECT_LT((a - Rgb(0.12, 0.11, 0.10)).norm(), 1e-9);
}

// A large patch under a lamp: the camera's pixels see only part of it, so their mean radiance
// belongs to the irradiance at those pixels, not to the patch's average.
TEST(ReflectanceTest, PixelPointsMakeTheEstimateExactWherePatchAveragesAreNot) {
  Mesh mesh;
  const Rgb albedo(0.6, 0.5, 0.3);
  const int m = mesh.AddMaterial({"floor", albedo, Rgb::Zero()});
  mesh.AddTriangle({-10, -10, 0}, {10, -10, 0}, {0, 10, 0}, m);
  HierarchyOptions ho;
  ho.max_patch_edge_m = 100.0;
  const PatchHierarchy h(mesh, ho);
  ASSERT_EQ(h.LeafCount(), 1);
  const RayCaster caster(mesh.geometry);
  RadianceObservation obs;
  const Eigen::Vector3d lamp(0.5, -0.5, 1.5);
  obs.lighting.point_lights.push_back({lamp, Rgb(20, 18, 15)});
  obs.pixel_points.resize(1);
  Rgb sum = Rgb::Zero();
  for (int i = 0; i < 40; ++i) {  // "pixels" along a line through the lamp's hot spot
    const Eigen::Vector3d x(-1.0 + 0.05 * i, -0.5 + 0.02 * i, 0.0);
    obs.pixel_points[0].push_back(x.cast<float>());
    const double r = (lamp - x).norm();
    sum += albedo.cwiseProduct(obs.lighting.point_lights[0].intensity_w_per_sr) * (lamp.z() / (r * r * r)) /
           std::numbers::pi;
  }
  obs.radiance = {sum / 40.0};
  ReflectanceOptions options;
  options.indirect_skip_tolerance = 0.01;  // open ground: no radiosity
  options.boundary_samples = 0;
  const ReflectanceResult at_pixels = EstimateReflectance(h, caster, {obs}, options);
  ASSERT_TRUE(at_pixels.radiosity_skipped) << at_pixels.reason;
  EXPECT_LT((at_pixels.albedo[0] - albedo).cwiseAbs().maxCoeff(), 1e-6);
  // Without the points the same photograph reads as a different albedo (clamped at 1 here).
  obs.pixel_points.clear();
  const ReflectanceResult spread = EstimateReflectance(h, caster, {obs}, options);
  EXPECT_GT((spread.albedo[0] - albedo).cwiseAbs().maxCoeff(), 0.1);
  // Point lists must come one per patch.
  obs.pixel_points.resize(2);
  EXPECT_THROW(EstimateReflectance(h, caster, {obs}, options), InvalidArgumentError);
}

TEST(ReflectanceTest, ScaleFactorIsLeastSquares) {
  const std::vector<Rgb> radiance = {Rgb(1, 2, 3), Rgb(0.5, 0.1, 0.2), Rgb(4, 4, 4)};
  std::vector<Rgb> reference;
  for (const Rgb& l : radiance) reference.push_back(2.5 * l);
  int used = 0;
  EXPECT_NEAR(RadianceScaleFactor(radiance, reference, {true, true, true}, &used), 2.5, 1e-12);
  EXPECT_EQ(used, 3);
  // Empty mask and all-black input: defined outcome, scale 1 and nothing used.
  EXPECT_EQ(RadianceScaleFactor(radiance, reference, {false, false, false}, &used), 1.0);
  EXPECT_EQ(used, 0);
  EXPECT_EQ(RadianceScaleFactor(std::vector<Rgb>(3, Rgb::Zero()), reference, {true, true, true}, &used), 1.0);
  EXPECT_EQ(used, 0);
}

TEST(ReflectanceTest, WrongSizesAndNoImagesThrow) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"a", Rgb::Constant(0.5), Rgb::Zero()});
  mesh.AddQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m);
  const PatchHierarchy h(mesh, HierarchyOptions{});
  const RayCaster caster(mesh.geometry);
  EXPECT_THROW(EstimateReflectance(h, caster, {}, {}), InvalidArgumentError);
  RadianceObservation obs;
  obs.radiance.assign(1, Rgb::Zero());
  EXPECT_THROW(EstimateReflectance(h, caster, {obs}, {}), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::radiosity
