// The IRM pipeline of `relume process`: the scene geometry it builds (from the simulated world,
// from an OBJ in UTM), its accuracy against the world's truth on noise-free input, and the
// command end to end on a small captured session (outputs, truth, stage reuse, errors).
#include "pipeline/irm_pipeline.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <string>

#include "calibration/image_file.h"
#include "calibration/testing/lens.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/frames.h"
#include "core/time.h"
#include "pipeline/irm_scene.h"
#include "pipeline/radiance.h"
#include "processing/irm/relight.h"
#include "processing/irm/testing_reference.h"
#include "rig/rig_config.h"
#include "rig/scene_model_from_rig.h"
#include "tests/apps/cli_runner.h"
#include "tests/apps/lens_copy.h"

namespace relume::pipeline {
namespace {
namespace fs = std::filesystem;
using relume::testing::ReadJsonFile;

const std::string kSource = RELUME_SOURCE_DIR;

fs::path TempDir(const std::string& name) {
  return relume::testing::FreshTempDir("irm_test", name);
}

TEST(IrmSceneTest, SplitTrianglesKeepTheSurfaceAndTheirFlatNormals) {
  sim::TriangleMesh box = sim::MakeBox({0, 0, 5}, {12, 8, 10}, 0.0);
  IrmMeshOptions options;
  options.spacing_m = 1.0;
  const TriangleMesh mesh = ProcessingMeshFromData(box, options);
  std::string why;
  ASSERT_TRUE(mesh.IsValid(&why)) << why;
  double area = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.positions[static_cast<std::size_t>(t[0])];
    const Eigen::Vector3f cross =
        (mesh.positions[static_cast<std::size_t>(t[1])] - a).cross(mesh.positions[static_cast<std::size_t>(t[2])] - a);
    area += 0.5 * cross.norm();
    // Winding and the stored normal agree (outward), and no normal blends across a crease.
    EXPECT_GT(cross.normalized().dot(mesh.normals[static_cast<std::size_t>(t[0])]), 0.9999f);
  }
  EXPECT_NEAR(area, 2 * (12 * 8 + 12 * 10 + 8 * 10), 1e-2);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f e =
          mesh.positions[static_cast<std::size_t>(t[(k + 1) % 3])] - mesh.positions[static_cast<std::size_t>(t[k])];
      ASSERT_LE(e.norm(), 1.0f * std::sqrt(2.0f) + 1e-4f);  // split edges, the diagonal of a unit cell at most
    }
  }
}

TEST(IrmSceneTest, UtmMeshLandsOnTheEnuSceneWithTheMeridianConvergence) {
  const rig::RigConfig rig = rig::LoadRigConfig(kSource + "/tests/data/rigs/sim-tiny-irm.yaml");
  IrmMeshOptions options;
  options.spacing_m = 50.0;  // geometry only: no need for dense vertices
  const LoadedSceneMesh utm =
      LoadSceneMesh(kSource + "/config/scenes/meshes/building-utm.obj", MeshFrame::kUtm, rig.site, 34, options);
  EXPECT_EQ(utm.utm_zone, 34);
  EXPECT_NEAR(utm.convergence_rad * 180.0 / 3.14159265358979, 1.678, 0.001);
  // Every corner of the ENU scene's building, annex and tower is a vertex of the converted mesh
  // (within 5 mm); read as if it were ENU, the file would be hundreds of kilometres off.
  for (const char* name : {"building", "annex", "tower"}) {
    const sim::SceneObject& object =
        rig.world->scene().objects[static_cast<std::size_t>(rig.world->scene().ObjectIndex(name))];
    for (const Eigen::Vector3d& corner : object.mesh.vertices) {
      double nearest = 1e9;
      for (const Eigen::Vector3f& p : utm.mesh.positions)
        nearest = std::min(nearest, (p.cast<double>() - corner).norm());
      EXPECT_LT(nearest, 0.005) << name << " corner " << corner.transpose();
    }
  }
  EXPECT_THROW(
      LoadSceneMesh(kSource + "/config/scenes/outdoor-building.yaml", MeshFrame::kEnu, rig.site, std::nullopt, options),
      InvalidArgumentError);
}

TEST(IrmSetJsonTest, RoundTripKeepsEveryRatio) {
  std::vector<irm::Sample> samples;
  const Eigen::Vector3f sun_s(0.8f, 0.1f, 0.59f), sun_t(-0.4f, -0.2f, 0.89f);
  for (int i = 0; i < 400; ++i) {
    const float a = 0.05f * static_cast<float>(i);
    irm::Sample s;
    s.normal = Eigen::Vector3f(std::cos(a) * 0.6f, std::sin(a) * 0.6f, 0.8f).normalized();
    s.source_sun = (i % 3 == 0) ? 0.0f : 1.0f;
    s.target_sun = (i % 5 == 0) ? 0.0f : 1.0f;
    const float e_s = 10.0f * s.source_sun * std::max(0.0f, s.normal.dot(sun_s.normalized())) + 1.0f;
    const float e_t = 12.0f * s.target_sun * std::max(0.0f, s.normal.dot(sun_t.normalized())) + 0.8f;
    s.source_rgb = Eigen::Vector3f::Constant(0.3f * e_s);
    s.target_rgb = Eigen::Vector3f::Constant(0.3f * e_t);
    samples.push_back(s);
  }
  irm::IrmSet set = irm::BuildIrms(samples, sun_s.normalized(), sun_t.normalized(), irm::IrmOptions{});
  // The interreflection's model terms travel too (the per-vertex light goes to its own file).
  set.model.indirect_scale = Eigen::Vector3f(0.01f, 0.02f, 0.03f);
  set.model.indirect_reason = "a reason";
  set.indirect_share.source_shadow = 0.4;
  set.indirect_share.target_lit_samples = 17;
  const irm::IrmSet back = IrmSetFromJson(ReadJsonFile([&] {
    const fs::path path = TempDir("json") / "irms.json";
    std::ofstream(path) << IrmSetToJson(set).dump();
    return path;
  }()));
  EXPECT_EQ(back.single_map, set.single_map);
  EXPECT_EQ(back.model.indirect_scale, set.model.indirect_scale);
  EXPECT_EQ(back.model.indirect_reason, "a reason");
  EXPECT_EQ(back.indirect_share.source_shadow, 0.4);
  EXPECT_EQ(back.indirect_share.target_lit_samples, 17);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3f n = samples[static_cast<std::size_t>(i)].normal;
    for (const auto& [fs_, ft] : {std::pair{1.0f, 1.0f}, {0.0f, 1.0f}, {0.5f, 0.2f}}) {
      const Eigen::Vector3f a = set.Ratio(n, fs_, ft), b = back.Ratio(n, fs_, ft);
      for (int c = 0; c < 3; ++c) {
        if (std::isnan(a[c])) {
          EXPECT_TRUE(std::isnan(b[c]));
        } else {
          EXPECT_EQ(a[c], b[c]);
        }
      }
    }
  }
}

// Noise-free input: the world's own renders at 09:00 and 15:00 from the DSLR's pose, 320x240.
// The source relit to 15:00 against the 15:00 render, per region. The renders use 256 sky and
// 64 sun-disk rays per pixel instead of the scene's 32 and 8: with 32 fixed sky directions the
// world's own sky irradiance near an occluder is off by a few per cent (the building's shaded
// face by 1.6 %), which is the truth's quadrature error, not the relighting's. With bounces, 256
// first-bounce rays per pixel for the same reason (64 left 4.4 % shadow error of render noise).
struct NoiseFreeCase {
  metrics::SunRegionErrors relit, baseline;
  irm::RelightSummary summary;
  int shadow_geometry_mismatch = 0;
};

NoiseFreeCase RunNoiseFree(bool penumbra, bool sky_gradient = true, int width = 320, int height = 240, int bounces = 0,
                           bool indirect = true) {
  const rig::RigConfig rig = rig::LoadRigConfig(kSource + "/tests/data/rigs/sim-tiny-irm.yaml");
  const PinholeCamera& device = rig.devices.front().camera;
  PinholeCamera camera = device;
  camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, DegToRad(70.0));
  const UtcTime morning = ParseIso8601("2026-06-21T09:00:00+03:00").utc;
  const UtcTime afternoon = ParseIso8601("2026-06-21T15:00:00+03:00").utc;
  sim::RenderOptions quality = rig.world->options();
  quality.sky_samples = 256;
  quality.sun_samples = 64;
  quality.indirect_bounces = bounces;
  quality.indirect_samples = 256;
  const sim::World world(rig.world->scene(), quality);
  // The renders, once per size and bounce count (the interreflection test relights them twice).
  static std::map<std::tuple<int, int, int>, std::pair<sim::GroundTruth, sim::GroundTruth>> renders;
  auto [it, fresh] = renders.try_emplace({width, height, bounces});
  if (fresh) it->second = {world.Render(camera, morning), world.Render(camera, afternoon)};
  const sim::GroundTruth& source = it->second.first;
  const sim::GroundTruth& target = it->second.second;
  const TriangleMesh mesh = ProcessingMeshFromModel(rig::SceneModelFromRig(rig), IrmMeshOptions{});
  const RayCaster caster(mesh);
  irm::RelightOptions options;
  options.use_penumbra_fractions = penumbra;
  options.sky_gradient = sky_gradient;
  options.indirect = indirect;
  const irm::RelightResult result =
      irm::RelightImage(caster, {&source.radiance, camera, rig.world->SunDirection(morning).cast<float>(), {}},
                        {&target.radiance, camera, rig.world->SunDirection(afternoon).cast<float>(), {}}, options);
  cv::Mat use;
  cv::compare(result.status, cv::Scalar(irm::kRelit), use, cv::CMP_EQ);
  const cv::Mat agree = GeometryAgreement(caster, camera, source.depth_m);
  const cv::Mat shadows_agree =
      ShadowAgreement(caster, camera, agree,
                      {{world.SunDirection(morning).cast<float>(), &source.sun_visibility},
                       {world.SunDirection(afternoon).cast<float>(), &target.sun_visibility}});
  NoiseFreeCase c;
  c.shadow_geometry_mismatch = cv::countNonZero(agree) - cv::countNonZero(shadows_agree);
  use &= shadows_agree;
  cv::Mat error_image;
  c.relit = metrics::CompareSunRegions(result.relit.pixels, target.radiance.pixels, source.sun_visibility,
                                       target.sun_visibility, use, metrics::Scale::kFitted, &error_image);
  if (const char* dump = std::getenv("RELUME_IRM_TEST_DUMP")) {
    const std::string prefix = std::string(dump) + "/noise_free_b" + std::to_string(bounces) +
                               (indirect ? "" : "_direct") + (penumbra ? "" : "_bits") +
                               (sky_gradient ? "" : "_uniform");
    calibration::SaveImage(error_image, prefix + "_error.png");
    calibration::SaveImage(pipeline::RadiancePreview(result.relit, 0.0), prefix + "_relit.png");
    calibration::SaveImage(pipeline::RadiancePreview(target.radiance, 0.0), prefix + "_target.png");
    calibration::SaveImage(pipeline::RadiancePreview(source.radiance, 0.0), prefix + "_source.png");
    calibration::SaveRadianceExr(result.relit, prefix + "_relit.exr");
    calibration::SaveRadianceExr(target.radiance, prefix + "_target.exr");
    calibration::SaveRadianceExr(source.radiance, prefix + "_source.exr");
  }
  c.baseline = metrics::CompareSunRegions(source.radiance.pixels, target.radiance.pixels, source.sun_visibility,
                                          target.sun_visibility, use, metrics::Scale::kFitted);
  c.summary = result.summary;
  std::printf(
      "bounces %d indirect %d penumbra %d: relit lit %.4f shadow %.4f penumbra %.4f all %.4f (pixels %lld/%lld/%lld, "
      "scale %.4f); "
      "no relighting %.4f %.4f %.4f %.4f; shadow geometry mismatch %d pixels\n",
      bounces, indirect, penumbra, c.relit.lit, c.relit.shadow, c.relit.penumbra, c.relit.all,
      static_cast<long long>(c.relit.lit_pixels), static_cast<long long>(c.relit.shadow_pixels),
      static_cast<long long>(c.relit.penumbra_pixels), c.relit.scale, c.baseline.lit, c.baseline.shadow,
      c.baseline.penumbra, c.baseline.all, c.shadow_geometry_mismatch);
  std::printf("  %s\n", result.summary.irm_summary.c_str());
  return c;
}

TEST(IrmAccuracyTest, NoiseFreeRelightingBeatsTheBaselineInEveryRegion) {
  const NoiseFreeCase with = RunNoiseFree(true);
  EXPECT_GT(with.relit.lit_pixels, 20000);
  EXPECT_GT(with.relit.shadow_pixels, 5000);
  // docs/irm.md: lit 0.13%, shadow 1.2% (issue 8's goal: 2%), against 91% and 101% without
  // relighting. Pixels where the mesh's shadows differ from the world's (the tessellated
  // dome's polygonal shadow) are left out: a handful.
  EXPECT_LT(with.shadow_geometry_mismatch, 50);
  EXPECT_LT(with.relit.lit, 0.01);
  EXPECT_LT(with.relit.shadow, 0.02);
  EXPECT_LT(with.relit.penumbra, with.baseline.penumbra);
  EXPECT_LT(with.relit.all, 0.1 * with.baseline.all);
  // The scale is a true one: noise-free renders share the world's units.
  EXPECT_NEAR(with.relit.scale, 1.0, 0.02);
  // The paper's shadow bits instead of fractions: still far better than no relighting.
  const NoiseFreeCase bits = RunNoiseFree(false);
  EXPECT_LT(bits.relit.lit, 0.01);
  EXPECT_LT(bits.relit.all, 0.2 * bits.baseline.all);
  // The world's sky is twice as bright at the horizon as at the zenith (in red): weighing every
  // sky direction alike, the ground that sees mostly zenith is misjudged (2.4% in shadow; 1.45%
  // since oblique ground gives samples, 2026-12-02, against 0.97% with the sky's shape).
  const NoiseFreeCase uniform = RunNoiseFree(true, /*sky_gradient=*/false);
  EXPECT_GT(uniform.relit.shadow, 1.4 * with.relit.shadow);
}

// Issue 26: the world rendered with interreflection (3 diffuse bounces; the building, annex and
// dome are bright and light the ground and each other). The IRM's sun + sky model alone has no
// term for that light; with the light gathered from the photographs (processing/irm/indirect.h)
// the relit source meets the goal of the direct-light case again.
TEST(IrmAccuracyTest, InterreflectionIsGatheredFromThePhotographs) {
  const NoiseFreeCase with = RunNoiseFree(true, true, 320, 240, /*bounces=*/3, /*indirect=*/true);
  const NoiseFreeCase without = RunNoiseFree(true, true, 320, 240, /*bounces=*/3, /*indirect=*/false);
  EXPECT_GT(with.relit.lit_pixels, 20000);
  EXPECT_GT(with.relit.shadow_pixels, 5000);
  EXPECT_GT(with.summary.indirect_rays, 0);
  EXPECT_NE(with.summary.irm_summary.find("indirect light (share"), std::string::npos) << with.summary.irm_summary;
  // docs/irm.md (2026-12-03): lit 0.44 %, shadow 2.77 % with the gathered light; 1.43 % and
  // 17.3 % without (the renders with 256 first-bounce rays per pixel: with 64 their Monte Carlo
  // noise, which the relit image inherits, made the shadow 4.4 %). Issue 26's goal: 2 % / 3 %.
  EXPECT_LT(with.relit.lit, 0.007);
  EXPECT_LT(with.relit.shadow, 0.035);
  EXPECT_LT(with.relit.shadow, 0.35 * without.relit.shadow);
  EXPECT_LT(with.relit.lit, 0.6 * without.relit.lit);
  EXPECT_NEAR(with.relit.scale, 1.0, 0.02);
}

// RelightPixels against its plain per-pixel definition (processing/irm/testing_reference.h) on
// the simulated world's noise-free renders: the dome's smooth vertex normals take the
// per-pixel path, the flat walls and ground the per-triangle one.
TEST(IrmAccuracyTest, RelightPixelsMatchesItsDefinitionOnTheWorld) {
  const rig::RigConfig rig = rig::LoadRigConfig(kSource + "/tests/data/rigs/sim-tiny-irm.yaml");
  PinholeCamera camera = rig.devices.front().camera;
  camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(320, 240, DegToRad(70.0));
  const UtcTime morning = ParseIso8601("2026-06-21T09:00:00+03:00").utc;
  const UtcTime afternoon = ParseIso8601("2026-06-21T15:00:00+03:00").utc;
  const sim::GroundTruth source = rig.world->Render(camera, morning);
  const sim::GroundTruth target = rig.world->Render(camera, afternoon);
  const TriangleMesh mesh = ProcessingMeshFromModel(rig::SceneModelFromRig(rig), IrmMeshOptions{});
  int smooth_triangles = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f& n0 = mesh.normals[static_cast<std::size_t>(t[0])];
    smooth_triangles +=
        n0 != mesh.normals[static_cast<std::size_t>(t[1])] || n0 != mesh.normals[static_cast<std::size_t>(t[2])];
  }
  ASSERT_GT(smooth_triangles, 100);  // the dome
  const RayCaster caster(mesh);
  for (const bool penumbra : {true, false}) {
    irm::RelightOptions options;
    options.use_penumbra_fractions = penumbra;
    const irm::View s{&source.radiance, camera, rig.world->SunDirection(morning).cast<float>(), {}};
    const irm::View t{&target.radiance, camera, rig.world->SunDirection(afternoon).cast<float>(), {}};
    const irm::ViewGeometry gs = irm::ComputeViewGeometry(caster, s, options);
    const irm::ViewGeometry gt = irm::ComputeViewGeometry(caster, t, options, /*with_sky_view=*/false);
    irm::RelightSummary summary;
    const irm::IrmSet irms = irm::BuildIrmsFromViews(caster, s, t, gs, gt, options, &summary);
    const irm::RelightResult fast = irm::RelightPixels(caster, s, t, gs, gt, irms, options, summary);
    const irm::RelightResult plain = irm::testing::RelightPixelsByDefinition(caster, s, t, gs, gt, irms, options);
    const irm::testing::RelightDifference d = irm::testing::CompareRelightings(fast, plain);
    std::printf("penumbra %d: %lld relit, %lld with own sun rays; largest relative difference %.2e\n", penumbra,
                static_cast<long long>(fast.summary.pixels_relit),
                static_cast<long long>(fast.summary.pixels_with_own_sun_rays), d.max_relative);
    EXPECT_EQ(d.status_differs, 0);
    EXPECT_EQ(d.fraction_differs, 0);
    EXPECT_LE(d.max_relative, 1e-5);
    EXPECT_GT(fast.summary.pixels_relit, 20000);
  }
}

// Counts the decisions of a run with this action, per stage prefix.
int Count(const nlohmann::json& summary, const std::string& action, const std::string& stage_prefix = "") {
  int n = 0;
  for (const nlohmann::json& d : summary["decisions"]) {
    n += d["action"] == action && d["stage"].get<std::string>().rfind(stage_prefix, 0) == 0;
  }
  return n;
}

// The IRM stages (names starting "irm-") the summary records with `action`.
std::set<std::string> Stages(const nlohmann::json& summary, const std::string& action) {
  std::set<std::string> stages;
  for (const nlohmann::json& d : summary["decisions"]) {
    const std::string stage = d["stage"];
    if (d["action"] == action && stage.rfind("irm-", 0) == 0) stages.insert(stage);
  }
  return stages;
}

TEST(IrmCliTest, RelightsACapturedSessionBeatsNoRelightingAndReusesStages) {
  const fs::path dir = TempDir("cli");
  const fs::path session = dir / "session";
  const testing::CliResult capture =
      testing::RunRelume("capture --rig " + kSource + "/tests/data/rigs/sim-tiny-irm.yaml --out " + session.string());
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const fs::path out = dir / "irm";
  const std::string base = "process " + session.string() + " --pipeline irm --source bracket:1 --target bracket:2";
  const std::string command = base + " --out " + out.string();

  const testing::CliResult first = testing::RunRelume(command);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const nlohmann::json summary = ReadJsonFile(out / "summary.json");
  // The mesh, two views and their sky shapes, the build, the relighting and the truth comparison.
  const std::set<std::string> all_irm = {"irm-mesh",       "irm-view-source", "irm-sky-source", "irm-view-target",
                                         "irm-sky-target", "irm-build",       "irm-relight",    "irm-truth"};
  EXPECT_EQ(Stages(summary, "run"), all_irm) << first.output;
  EXPECT_NE(first.output.find("four IRMs:"), std::string::npos) << first.output;
  for (const nlohmann::json& o : summary["outputs"]) {
    EXPECT_TRUE(fs::exists(out / o["path"].get<std::string>())) << o.dump();
  }
  std::string outputs = summary["outputs"].dump();
  for (const char* name : {"relit.exr", "relit.png", "status.png", "seam_difference.exr", "irm_lit_to_lit.exr",
                           "irm_shadow_to_lit.exr", "truth_error.png"}) {
    EXPECT_NE(outputs.find(name), std::string::npos) << name;
  }
  const nlohmann::json& m = summary["metrics"];
  const nlohmann::json& relit = m["truth"]["relit"];
  const nlohmann::json& baseline = m["truth"]["no_relighting"];
  // With sensor noise (14-bit raw, 160x120): lit within a few per cent, every region far better
  // than not relighting (docs/irm.md has the numbers).
  EXPECT_LT(relit["relative_rms_lit"].get<double>(), 0.04) << m.dump(1);
  EXPECT_LT(relit["relative_rms_all"].get<double>(), 0.3 * baseline["relative_rms_all"].get<double>()) << m.dump(1);
  EXPECT_LT(relit["relative_rms_shadow"].get<double>(), 0.1) << m.dump(1);  // 0.23 without the sky view
  EXPECT_GT(relit["lit_pixels"].get<int>(), 3000);
  EXPECT_GT(m["irm"]["pixels_without_geometry"].get<int>(), 1000);  // the sky, untouched
  EXPECT_LT(m["irm"]["seam"]["overlap_relative_rms_after"].get<double>(),
            0.3 * m["irm"]["seam"]["overlap_relative_rms_before"].get<double>())
      << m["irm"].dump(1);
  EXPECT_LT(m["truth"]["target_sun_direction_error_deg"].get<double>(), 0.05);

  // Unchanged: everything reused. A new bin count: views reused, build and relighting redone.
  // New sun-disk samples: views too.
  ASSERT_EQ(testing::RunRelume(command).exit_code, 0);
  const nlohmann::json again = ReadJsonFile(out / "summary.json");
  EXPECT_EQ(Count(again, "reuse"), 10) << again["decisions"].dump(1);  // 2 radiance + 8 irm
  EXPECT_EQ(Count(again, "run"), 0);
  EXPECT_EQ(again["metrics"]["truth"], summary["metrics"]["truth"]);  // the same figures, from the stage
  ASSERT_EQ(testing::RunRelume(command + " --set bins=16").exit_code, 0);
  const nlohmann::json bins = ReadJsonFile(out / "summary.json");
  EXPECT_EQ(Stages(bins, "run"), (std::set<std::string>{"irm-build", "irm-relight", "irm-truth"}))
      << bins["decisions"].dump(1);
  ASSERT_EQ(testing::RunRelume(command + " --set sun_samples=4").exit_code, 0);
  const nlohmann::json samples = ReadJsonFile(out / "summary.json");
  std::set<std::string> after_views = all_irm;
  after_views.erase("irm-mesh");
  EXPECT_EQ(Stages(samples, "run"), after_views) << samples["decisions"].dump(1);
  EXPECT_EQ(Count(samples, "reuse", "radiance"), 2) << samples["decisions"].dump(1);

  // Without --source and --target: the earliest and the latest bracket of the camera.
  const testing::CliResult chosen = testing::RunRelume("process " + session.string() +
                                                       " --pipeline irm --explain --out " + (dir / "chosen").string());
  EXPECT_EQ(chosen.exit_code, 0) << chosen.output;
  EXPECT_NE(chosen.output.find("relight bracket:1 to bracket:2"), std::string::npos) << chosen.output;

  // Errors a user can make, each named.
  const testing::CliResult no_target =
      testing::RunRelume("process " + session.string() + " --pipeline irm --source bracket:1");
  EXPECT_NE(no_target.exit_code, 0);
  EXPECT_NE(no_target.output.find("needs --target FRAME"), std::string::npos) << no_target.output;
  const testing::CliResult two =
      testing::RunRelume("process " + session.string() + " --pipeline irm --source all --target bracket:2");
  EXPECT_NE(two.exit_code, 0);
  EXPECT_NE(two.output.find("selects 2 still brackets"), std::string::npos) << two.output;
  const testing::CliResult no_mesh = testing::RunRelume(command + " --mesh " + (dir / "none.obj").string());
  EXPECT_NE(no_mesh.exit_code, 0);
  EXPECT_NE(no_mesh.output.find("does not exist"), std::string::npos) << no_mesh.output;
  const testing::CliResult bad_frame = testing::RunRelume(
      command + " --mesh " + kSource + "/config/scenes/meshes/building-utm.obj --set mesh_frame=gps");
  EXPECT_NE(bad_frame.exit_code, 0);
  EXPECT_NE(bad_frame.output.find("mesh_frame=gps: expected enu or utm"), std::string::npos) << bad_frame.output;
  fs::remove_all(dir);
}

// A mesh in UTM (grid north 1.678 deg off true north) on a session of the world it describes:
// converted through geodetic coordinates, it must relight as well as the session's recorded
// world. (On the world with the dome, which the mesh lacks, it cannot: the dome hides and
// shadows surfaces the mesh shows open and lit.)
TEST(IrmCliTest, AUtmMeshRelightsAsWellAsTheRecordedWorld) {
  const fs::path dir = TempDir("utm");
  const fs::path session = dir / "session";
  const testing::CliResult capture = testing::RunRelume(
      "capture --rig " + kSource + "/tests/data/rigs/sim-tiny-irm-no-dome.yaml --out " + session.string());
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const std::string base = "process " + session.string() + " --pipeline irm --source bracket:1 --target bracket:2";
  const testing::CliResult world = testing::RunRelume(base + " --out " + (dir / "world").string());
  ASSERT_EQ(world.exit_code, 0) << world.output;
  const testing::CliResult utm =
      testing::RunRelume(base + " --mesh " + kSource +
                         "/config/scenes/meshes/building-utm.obj --set mesh_frame=utm --out " + (dir / "utm").string());
  ASSERT_EQ(utm.exit_code, 0) << utm.output;
  EXPECT_NE(utm.output.find("meridian convergence 1.678"), std::string::npos) << utm.output;
  const nlohmann::json a = ReadJsonFile(dir / "world" / "summary.json")["metrics"]["truth"]["relit"];
  const nlohmann::json b = ReadJsonFile(dir / "utm" / "summary.json")["metrics"]["truth"]["relit"];
  // docs/irm.md: lit 0.0081 / 0.0080, shadow 0.040 / 0.039 (world / UTM mesh).
  EXPECT_LT(b["relative_rms_lit"].get<double>(), 0.02) << b.dump(1);
  EXPECT_LT(b["relative_rms_shadow"].get<double>(), 0.1) << b.dump(1);
  EXPECT_NEAR(b["relative_rms_lit"].get<double>(), a["relative_rms_lit"].get<double>(), 0.005) << a.dump(1);
  EXPECT_NEAR(b["relative_rms_shadow"].get<double>(), a["relative_rms_shadow"].get<double>(), 0.01) << a.dump(1);
  fs::remove_all(dir);
}

// The real-data path (docs/real-data.md): a scene model written by hand (the camera measured in
// ENU, the site's photogrammetry mesh in UTM) and stored with `session add-scene-model --from`
// replaces the one capture wrote; processing then takes cameras and geometry from it and relights
// as well as from the simulated rig's own model.
TEST(IrmCliTest, AHandWrittenSceneModelRelightsAsWellAsTheRigsOwn) {
  const fs::path dir = TempDir("scene-file");
  const fs::path session = dir / "session";
  const testing::CliResult capture = testing::RunRelume(
      "capture --rig " + kSource + "/tests/data/rigs/sim-tiny-irm-no-dome.yaml --out " + session.string());
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const std::string base = "process " + session.string() + " --pipeline irm --source bracket:1 --target bracket:2";
  const testing::CliResult rig_model = testing::RunRelume(base + " --out " + (dir / "rig-model").string());
  ASSERT_EQ(rig_model.exit_code, 0) << rig_model.output;

  std::ofstream(dir / "scene.yaml") << "frame: enu\n"
                                       "utm_zone: 34\n"
                                       "cameras:\n"
                                       "  - device: sim:dslr\n"
                                       "    intrinsics: {width: 160, height: 120, horizontal_fov_deg: 70}\n"
                                       "    position_m: [-6, -34, 1.7]\n"
                                       "    look_at_m: [-2, 0, 5]\n"
                                       "objects:\n"
                                       "  - {name: site, kind: solid, frame: utm, mesh: "
                                    << kSource << "/config/scenes/meshes/building-utm.obj}\n";
  const testing::CliResult add =
      testing::RunRelume("session add-scene-model " + session.string() + " --from " + (dir / "scene.yaml").string());
  ASSERT_EQ(add.exit_code, 0) << add.output;
  EXPECT_NE(add.output.find("scene model stored as calibration row"), std::string::npos) << add.output;
  const testing::CliResult info = testing::RunRelume("session info " + session.string());
  EXPECT_NE(info.output.find("2 scene_model"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("from scene model file"), std::string::npos) << info.output;

  const testing::CliResult file_model = testing::RunRelume(base + " --out " + (dir / "file-model").string());
  ASSERT_EQ(file_model.exit_code, 0) << file_model.output;
  EXPECT_NE(file_model.output.find("scene model file"), std::string::npos) << file_model.output;
  const nlohmann::json a = ReadJsonFile(dir / "rig-model" / "summary.json")["metrics"]["truth"]["relit"];
  const nlohmann::json b = ReadJsonFile(dir / "file-model" / "summary.json")["metrics"]["truth"]["relit"];
  EXPECT_LT(b["relative_rms_lit"].get<double>(), 0.02) << b.dump(1);
  EXPECT_NEAR(b["relative_rms_lit"].get<double>(), a["relative_rms_lit"].get<double>(), 0.005) << a.dump(1);
  EXPECT_NEAR(b["relative_rms_shadow"].get<double>(), a["relative_rms_shadow"].get<double>(), 0.01) << a.dump(1);

  // A camera the model does not have: the pipeline says what to add.
  std::ofstream(dir / "no-camera.yaml") << "utm_zone: 34\nobjects:\n  - {name: site, kind: solid, frame: utm, mesh: "
                                        << kSource << "/config/scenes/meshes/building-utm.obj}\n";
  ASSERT_EQ(
      testing::RunRelume("session add-scene-model " + session.string() + " --from " + (dir / "no-camera.yaml").string())
          .exit_code,
      0);
  const testing::CliResult refused = testing::RunRelume(base + " --out " + (dir / "refused").string());
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("has none for it"), std::string::npos) << refused.output;
  fs::remove_all(dir);
}

// A simulated session recorded before capture stored scene models (its row removed here) is
// refused with the command that gives it one; that command writes the model from the rig and
// world the session keeps, once.
TEST(IrmCliTest, AnOlderSimulatedSessionGetsItsSceneModelFromItsStoredRig) {
  const fs::path dir = TempDir("old-session");
  const fs::path session = dir / "session";
  ASSERT_EQ(
      testing::RunRelume("capture --rig " + kSource + "/tests/data/rigs/sim-tiny-irm.yaml --out " + session.string())
          .exit_code,
      0);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((session / "session.sqlite").c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "DELETE FROM calibrations WHERE kind = 'scene_model'", nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_NE(testing::RunRelume("session info " + session.string()).output.find("scene model   none"),
            std::string::npos);

  const std::string process = "process " + session.string() + " --pipeline irm --out ";
  const testing::CliResult refused = testing::RunRelume(process + (dir / "refused").string());
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("relume session add-scene-model"), std::string::npos) << refused.output;

  const testing::CliResult add = testing::RunRelume("session add-scene-model " + session.string());
  ASSERT_EQ(add.exit_code, 0) << add.output;
  const testing::CliResult again = testing::RunRelume("session add-scene-model " + session.string());
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.output.find("already has a scene model"), std::string::npos) << again.output;
  const testing::CliResult run = testing::RunRelume(process + (dir / "run").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("the session's scene model"), std::string::npos) << run.output;
  fs::remove_all(dir);
}

// A camera posed from ground control points (`relume calibrate pose`, WGS84 coordinates as a
// GNSS survey gives them) relights as well as the rig's own pose. The marks are exact: on this
// 160 x 120 image a 0.05 px marking error (3 cm of camera height at 34 m) already moves the
// measured shadow error from 2 % to 10 %, because the truth is rendered from the estimated pose
// and shadow edges shift by a fraction of a pixel against the photographs (measured 2026-12-03;
// docs/real-data.md). The pose's accuracy under noise is calibration/camera_pose_test.cc's.
TEST(IrmCliTest, ACameraPosedFromControlPointsRelightsAsWellAsTheRigsOwn) {
  const fs::path dir = TempDir("gcp");
  const fs::path session = dir / "session";
  const std::string rig_file = kSource + "/tests/data/rigs/sim-tiny-irm-no-dome.yaml";
  ASSERT_EQ(testing::RunRelume("capture --rig " + rig_file + " --out " + session.string()).exit_code, 0);
  const std::string base = "process " + session.string() + " --pipeline irm --source bracket:1 --target bracket:2";
  ASSERT_EQ(testing::RunRelume(base + " --out " + (dir / "rig-pose").string()).exit_code, 0);

  // The site's mesh without a camera, then the camera from the control points.
  std::ofstream(dir / "scene.yaml") << "utm_zone: 34\nobjects:\n  - {name: site, kind: solid, frame: utm, mesh: "
                                    << kSource << "/config/scenes/meshes/building-utm.obj}\n";
  ASSERT_EQ(
      testing::RunRelume("session add-scene-model " + session.string() + " --from " + (dir / "scene.yaml").string())
          .exit_code,
      0);
  const rig::RigConfig rig = rig::LoadRigConfig(rig_file);
  const PinholeCamera& truth = rig.devices.front().camera;
  const EnuFrame enu(rig.site);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-12, 8), y(-6, 6), z(0, 12);
  std::ofstream gcp(dir / "gcp.csv");
  gcp << std::setprecision(12) << "name,u,v,lat,lon,h\n";
  for (int i = 0; i < 10;) {
    const Eigen::Vector3d p(x(rng), y(rng), z(rng));
    const Eigen::Vector2d px = truth.intrinsics.Project(truth.world_from_camera.inverse() * p);
    if (px.x() < 0 || px.y() < 0 || px.x() > truth.intrinsics.width || px.y() > truth.intrinsics.height) continue;
    const Site g = enu.GeodeticFromEnu(p);
    gcp << "gcp" << i++ << "," << px.x() << "," << px.y() << "," << g.latitude_deg() << "," << g.longitude_deg() << ","
        << g.height_m << "\n";
  }
  gcp.close();
  const testing::CliResult pose =
      testing::RunRelume("calibrate pose --session " + session.string() + " --device sim:dslr --gcp " +
                         (dir / "gcp.csv").string() + " --gcp-frame wgs84 --fov 70");
  ASSERT_EQ(pose.exit_code, 0) << pose.output;
  EXPECT_NE(pose.output.find("RMS over 10 inliers"), std::string::npos) << pose.output;
  const std::optional<SceneModel> model = capture::LatestSceneModel(session);
  ASSERT_TRUE(model.has_value());
  ASSERT_NE(model->FindCamera("sim:dslr"), nullptr);
  EXPECT_LT(
      (model->FindCamera("sim:dslr")->camera.world_from_camera.translation() - truth.world_from_camera.translation())
          .norm(),
      1e-3);
  EXPECT_EQ(model->objects.size(), 1u);  // the mesh stored before stays

  const testing::CliResult posed = testing::RunRelume(base + " --out " + (dir / "gcp-pose").string());
  ASSERT_EQ(posed.exit_code, 0) << posed.output;
  EXPECT_NE(posed.output.find("ground control points"), std::string::npos) << posed.output;
  const nlohmann::json a = ReadJsonFile(dir / "rig-pose" / "summary.json")["metrics"]["truth"]["relit"];
  const nlohmann::json b = ReadJsonFile(dir / "gcp-pose" / "summary.json")["metrics"]["truth"]["relit"];
  EXPECT_NEAR(b["relative_rms_lit"].get<double>(), a["relative_rms_lit"].get<double>(), 0.005)
      << a.dump(1) << b.dump(1);
  EXPECT_NEAR(b["relative_rms_shadow"].get<double>(), a["relative_rms_shadow"].get<double>(), 0.02)
      << a.dump(1) << b.dump(1);
  fs::remove_all(dir);
}

// The pinhole frame back from a frame taken through the lens, as the pipeline undistorts one
// (bilinear), done here on the recorded counts.
CameraImage BackFromLens(const CameraImage& lens, const PinholeIntrinsics& k, const std::vector<double>& d) {
  const cv::Matx33d k_cv(k.fx, 0.0, k.cx - 0.5, 0.0, k.fy, k.cy - 0.5, 0.0, 0.0, 1.0);
  cv::Mat map_x, map_y;
  cv::initUndistortRectifyMap(k_cv, d, cv::noArray(), k_cv, cv::Size(k.width, k.height), CV_32FC1, map_x, map_y);
  CameraImage out = lens;
  cv::remap(lens.pixels, out.pixels, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

// A copy of `from` whose still frames went through a lens with distortion `d` (same times,
// exposures, brackets and stored rig), and, with `back`, undistorted again before they are
// stored; its scene model's camera says `model_distortion`.
void CopyThroughLens(const fs::path& from, const fs::path& to, const std::vector<double>& d,
                     const std::vector<double>& model_distortion, bool back = false) {
  const capture::SessionReader in(from);
  const std::unique_ptr<capture::SessionWriter> out = capture::SessionWriter::Create(to, in.info());
  for (const drivers::DeviceInfo& device : in.Devices()) out->AddDevice(device);
  const PinholeIntrinsics k = testing::CopySceneModelWithDistortion(in, *out, model_distortion);
  std::map<std::int64_t, std::int64_t> brackets;
  for (const capture::BracketRecord& b : in.Brackets())
    brackets[b.id] = out->BeginBracket(b.device_id, b.started_utc, b.planned_count);
  for (const capture::FrameRecord& f : in.Frames()) {
    if (f.stream != "still") continue;
    drivers::StillFrame frame;
    frame.device_id = f.device_id;
    // Linear counts interpolate physically (calibration/testing/lens.h).
    frame.image = in.LoadImage(f);
    frame.image.pixels = calibration::testing::ThroughLens(frame.image.pixels, k, d);
    if (back) frame.image = BackFromLens(frame.image, k, d);
    frame.exposure = f.exposure;
    frame.timing = {f.utc, f.monotonic, f.device_timestamp, f.sequence};
    out->WriteStillFrame(frame, f.bracket_id ? std::optional(brackets.at(*f.bracket_id)) : std::nullopt,
                         f.bracket_index);
  }
  for (const capture::BracketRecord& b : in.Brackets()) out->EndBracket(brackets.at(b.id), b.status, b.reason);
  fs::copy(from / "rig", to / "rig", fs::copy_options::recursive);
}

// A lens with distortion: the scene model's coefficients (as `calibrate intrinsics` fits them)
// undistort every bracket onto the model's pinhole camera. The floor: the same frames undistorted
// before they are stored (what resampling a 160x120 frame twice costs at the shadow edges); the
// pipeline's undistortion must be as good as that, and far better than taking the frames for
// pinhole frames.
TEST(IrmCliTest, ADistortedLensIsUndistortedAsWellAsItsFloorAndFarBetterThanIgnored) {
  const fs::path dir = TempDir("lens");
  const fs::path pinhole = dir / "pinhole";
  ASSERT_EQ(testing::RunRelume("capture --rig " + kSource + "/tests/data/rigs/sim-tiny-irm-no-dome.yaml --out " +
                               pinhole.string())
                .exit_code,
            0);
  const std::vector<double> lens{-0.18, 0.04, 0.001, -0.0015, 0.0};
  ASSERT_NO_FATAL_FAILURE(CopyThroughLens(pinhole, dir / "lens", lens, lens));
  ASSERT_NO_FATAL_FAILURE(CopyThroughLens(pinhole, dir / "floor", lens, {}, /*back=*/true));
  ASSERT_NO_FATAL_FAILURE(CopyThroughLens(pinhole, dir / "ignored", lens, {}));
  const auto process = [&](const std::string& session) {
    const testing::CliResult r = testing::RunRelume("process " + (dir / session).string() +
                                                    " --pipeline irm --source bracket:1 --target bracket:2 --out " +
                                                    (dir / (session + "-out")).string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return ReadJsonFile(dir / (session + "-out") / "summary.json");
  };
  const nlohmann::json a = process("pinhole");
  const nlohmann::json b = process("lens");
  const nlohmann::json f = process("floor");
  const nlohmann::json c = process("ignored");
  EXPECT_NE(b["decisions"].dump().find("undistorting onto the scene model's pinhole camera"), std::string::npos);
  EXPECT_EQ(c["decisions"].dump().find("undistorting"), std::string::npos);
  const auto lit = [](const nlohmann::json& s) {
    return s["metrics"]["truth"]["relit"]["relative_rms_lit"].get<double>();
  };
  const auto shadow = [](const nlohmann::json& s) {
    return s["metrics"]["truth"]["relit"]["relative_rms_shadow"].get<double>();
  };
  std::printf(
      "irm relit lit/shadow: pinhole %.4f/%.4f, lens undistorted %.4f/%.4f, floor %.4f/%.4f, "
      "lens ignored %.4f/%.4f\n",
      lit(a), shadow(a), lit(b), shadow(b), lit(f), shadow(f), lit(c), shadow(c));
  EXPECT_LT(lit(b), lit(f) * 1.1 + 0.005);
  EXPECT_LT(shadow(b), shadow(f) * 1.1 + 0.01);
  EXPECT_LT(lit(b), 0.5 * lit(c));
  EXPECT_LT(shadow(b), 0.8 * shadow(c));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::pipeline
