// Images from outside relume (issue 19): scripts/blender_dataset.sh renders a courtyard with
// Blender Cycles in the morning and the afternoon (JPEG brackets with EXIF written by exiv2, the
// geometry as OBJ), imports it as a session, adds the scene model from a scene file, and relights
// the morning to the afternoon with the IRM pipeline against Blender's own afternoon render
// (--set truth_dir). Nothing of relume's simulator is involved. Skipped, saying so, when Blender
// or exiv2 is not installed (scripts/install-deps.sh installs both).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/apps/cli_runner.h"

namespace {
namespace fs = std::filesystem;

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// scripts/blender_dataset.sh into a fresh temporary folder named after `name`, with `args`.
relume::testing::CliResult RunDataset(const std::string& name, const std::string& args, fs::path* out) {
  *out = fs::temp_directory_path() / ("relume_blender_" + name + "_" + std::to_string(::getpid()));
  return relume::testing::RunCommand("bash " + std::string(RELUME_SOURCE_DIR) + "/scripts/blender_dataset.sh " +
                                     RELUME_BINARY + " " + out->string() + args);
}

TEST(BlenderDatasetTest, AnImportedCyclesCourtyardIsRelitAgainstBlendersOwnRender) {
  fs::path out;
  const relume::testing::CliResult run = RunDataset("test", "", &out);
  if (run.exit_code == 77) GTEST_SKIP() << run.output;
  ASSERT_EQ(run.exit_code, 0) << run.output;

  // The import: two brackets of five JPEGs, time and exposure from the EXIF exiv2 wrote.
  EXPECT_NE(run.output.find("imported 10 frames of import:blender-cycles in 2 brackets"), std::string::npos)
      << run.output;
  const nlohmann::json summary = ReadJson(out / "irm" / "summary.json");
  const nlohmann::json& truth = summary["metrics"]["truth"];
  ASSERT_TRUE(truth.is_object()) << summary.dump(2);
  EXPECT_NE(truth["truth"].get<std::string>().find("external"), std::string::npos);
  EXPECT_EQ(truth["relit_pixels_off_the_truths_surfaces"].get<int>(), 0);
  const nlohmann::json& relit = truth["relit"];
  const nlohmann::json& before = truth["no_relighting"];
  const nlohmann::json& floor = truth["source_photograph"];
  EXPECT_GT(relit["lit_pixels"].get<int>(), 10000) << relit.dump(2);
  EXPECT_GT(relit["shadow_pixels"].get<int>(), 2000) << relit.dump(2);
  // Measured 2026-12-03 (Blender 3.4.1, 64 samples, direct light only): relit lit 3.4 %, shadow
  // 5.2 %; not relit 43 % and 139 %. The floor is the linearised source photograph itself (8-bit
  // JPEGs, the response recovered from the bracket) against an independent render of Blender's
  // (another sampling seed): 1.7 % and 5.6 %.
  EXPECT_LT(relit["relative_rms_lit"].get<double>(), 0.05) << truth.dump(2);
  EXPECT_LT(relit["relative_rms_shadow"].get<double>(), 0.08) << truth.dump(2);
  EXPECT_LT(relit["relative_rms_lit"].get<double>(), 0.2 * before["relative_rms_lit"].get<double>());
  EXPECT_LT(relit["relative_rms_shadow"].get<double>(), 0.1 * before["relative_rms_shadow"].get<double>());
  EXPECT_LT(floor["relative_rms_lit"].get<double>(), 0.03) << truth.dump(2);
  EXPECT_LT(relit["relative_rms_lit"].get<double>(), 3.0 * floor["relative_rms_lit"].get<double>()) << truth.dump(2);
  EXPECT_LT(relit["relative_rms_shadow"].get<double>(), 1.6 * floor["relative_rms_shadow"].get<double>())
      << truth.dump(2);
  // The report says it: the headline and the truth decision name the external truth.
  EXPECT_NE(run.output.find("relit vs the external truth"), std::string::npos) << run.output;

  // A truth folder without its files: the error names the file and what the folder needs.
  fs::create_directories(out / "empty");
  const relume::testing::CliResult missing =
      relume::testing::RunRelume("process " + (out / "session").string() + " --pipeline irm --out " +
                                 (out / "irm2").string() + " --set truth_dir=" + (out / "empty").string());
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("target.exr: does not exist; --set truth_dir needs"), std::string::npos)
      << missing.output;
  fs::remove_all(out);
}

// The room: a point lamp of stated intensity in two places, 8 diffuse bounces, a grey-scale chart of
// known albedo on a stand; the radiosity pipeline's albedo is absolute through the chart, and is
// scored against the materials Blender rendered with; its relit image against Blender's render
// under the relighting lamp.
TEST(BlenderDatasetTest, AnImportedCyclesRoomGetsItsAlbedoFromTheChart) {
  fs::path out;
  const relume::testing::CliResult run = RunDataset("room", " --scene room", &out);
  if (run.exit_code == 77) GTEST_SKIP() << run.output;
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json summary = ReadJson(out / "radiosity" / "summary.json");
  const nlohmann::json& metrics = summary["metrics"];
  const nlohmann::json& scale = metrics["absolute_scale"];
  EXPECT_EQ(scale["mode"], "chart") << scale.dump(2);
  EXPECT_TRUE(scale["converged"].get<bool>()) << scale.dump(2);
  EXPECT_GE(scale["reference_patches"].get<int>(), 8) << scale.dump(2);
  // Measured 2026-12-03 (Blender 3.4.1, 64 samples, 8 bounces): errors of the mean per material
  // 0.0016 (floor) .. 0.023 (the desk's top, red 0.468 for 0.50), mean 0.007 over 13 materials;
  // the relit image per patch 2.2 % (per pixel 7.5 %: the render's noise), mean ratio 0.987.
  const nlohmann::json& after = metrics["reflectance"]["truth_after"];
  double sum = 0.0, worst = 0.0;
  int materials = 0;
  for (const nlohmann::json& m : after["materials"]) {
    const double e = m["error_of_mean"].get<double>();
    sum += e;
    worst = std::max(worst, e);
    ++materials;
    if (m["material"] == "floor" || m["material"] == "ceiling" || m["material"] == "wall-west+wall-east" ||
        m["material"] == "wall-south+wall-north") {
      EXPECT_LT(e, 0.012) << m.dump();  // the room's large surfaces
    }
  }
  EXPECT_GE(materials, 10) << after.dump(2);
  EXPECT_LT(sum / materials, 0.012) << after.dump(2);
  EXPECT_LT(worst, 0.04) << after.dump(2);
  const nlohmann::json& relight = metrics["relight"];
  EXPECT_LT(relight["truth_relative_rms_per_patch"].get<double>(), 0.04) << relight.dump(2);
  EXPECT_NEAR(relight["truth_mean_ratio"].get<double>(), 1.0, 0.03) << relight.dump(2);
  EXPECT_NE(run.output.find("comparing with the external truth"), std::string::npos) << run.output;
  fs::remove_all(out);
}

// Issue 26: the courtyard rendered with 4 diffuse bounces, photographed as linear 16-bit TIFFs
// (a raw converter's output: `session import --linear`, no response to recover), so the floor
// is Blender's own Monte Carlo noise. The light the walls and the ground send each other is
// gathered from the photographs (processing/irm/indirect.h); without it (--set indirect=false)
// the relit shadows are half as far off again.
TEST(BlenderDatasetTest, ACyclesCourtyardWithInterreflectionIsRelitWithTheGatheredLight) {
  fs::path out;
  const relume::testing::CliResult run = RunDataset("bounces", " --bounces 4 --format tiff", &out);
  if (run.exit_code == 77) GTEST_SKIP() << run.output;
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json summary = ReadJson(out / "irm" / "summary.json");
  const nlohmann::json& truth = summary["metrics"]["truth"];
  const nlohmann::json& relit = truth["relit"];
  const nlohmann::json& floor = truth["source_photograph"];
  const nlohmann::json& indirect = summary["metrics"]["irm"]["indirect"];
  EXPECT_TRUE(indirect["used"].get<bool>()) << indirect.dump(2);
  EXPECT_GT(indirect["share_source_shadow"].get<double>(), 0.1) << indirect.dump(2);
  // q against what the source's sky radiance predicts: taken from it (both skies measured).
  for (const auto& ratio : indirect["scale_over_sky_prediction"]) EXPECT_NEAR(ratio.get<double>(), 1.0, 1e-3);

  const relume::testing::CliResult direct = relume::testing::RunRelume(
      "process " + (out / "session").string() + " --pipeline irm --out " + (out / "irm-direct").string() +
      " --set truth_dir=" + (out / "truth").string() + " --set indirect=false");
  ASSERT_EQ(direct.exit_code, 0) << direct.output;
  const nlohmann::json without = ReadJson(out / "irm-direct" / "summary.json")["metrics"]["truth"]["relit"];
  // Measured 2026-12-03 (64 samples): relit lit 2.7 %, shadow 5.2 % with the gathered light;
  // 3.8 % and 7.7 % without; floor (two independent renders) 3.0 % and 6.9 %.
  EXPECT_LT(relit["relative_rms_lit"].get<double>(), floor["relative_rms_lit"].get<double>()) << truth.dump(2);
  EXPECT_LT(relit["relative_rms_shadow"].get<double>(), floor["relative_rms_shadow"].get<double>()) << truth.dump(2);
  EXPECT_LT(1.3 * relit["relative_rms_shadow"].get<double>(), without["relative_rms_shadow"].get<double>())
      << without.dump(2);
  EXPECT_LT(1.2 * relit["relative_rms_lit"].get<double>(), without["relative_rms_lit"].get<double>())
      << without.dump(2);
  fs::remove_all(out);
}

// An RGB-D recording from outside relume (issue 19): Blender renders 12 frames of three objects
// under a key light circling them (30 deg a frame) and a fixed fill, as 8-bit colour PNGs and
// 16-bit millimetre depth PNGs in the TUM RGB-D layout; `session import --rgbd` makes the session
// and `--pipeline sh` relights every frame to the last frame's light, scored against Blender's
// linear render of the last frame (--set truth_dir). The dataset also computes the method's
// floor from Blender's true normals and lights (truth/sh_floor.json): what an order-2 SH model
// gets with perfect normals and light.
TEST(BlenderDatasetTest, AnImportedCyclesRgbdRecordingIsRelitWithShAgainstBlendersRender) {
  fs::path out;
  const relume::testing::CliResult run = RunDataset("rgbd", " --scene rgbd", &out);
  if (run.exit_code == 77) GTEST_SKIP() << run.output;
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("imported 12 RGB-D frame pairs of import:blender-cycles-rgbd"), std::string::npos)
      << run.output;
  const nlohmann::json metrics = ReadJson(out / "sh" / "summary.json")["metrics"];
  EXPECT_NE(metrics["truth"].get<std::string>().find("external"), std::string::npos);
  EXPECT_EQ(metrics["compared_frames"].get<int>(), 11) << metrics.dump(2);
  const double relit = metrics["relit_relative_rms_mean"].get<double>();
  const double baseline = metrics["baseline_relative_rms_mean"].get<double>();
  const double photograph = metrics["floor_relative_rms_mean"].get<double>();
  const nlohmann::json floor = ReadJson(out / "truth" / "sh_floor.json");
  const double sh2 = floor["mean_sh2_true_normals"].get<double>();
  // Measured 2026-12-03 (Blender 3.4.1, 64 samples, 3 bounces): relit 6.95 % (2026-12-07: 6.71 %) (not relit 22.4 %);
  // the floor, order-2 SH with Blender's true normals and lights, 6.91 % (the exact light ratio
  // 5.80 %: the objects' shadows on each other, which no per-pixel ratio of distant light holds);
  // the destination photograph itself 0.85 %.
  EXPECT_LT(photograph, 0.02) << metrics.dump(2);
  EXPECT_LT(relit, 0.4 * baseline) << metrics.dump(2);
  EXPECT_LT(relit, 0.09) << metrics.dump(2);
  EXPECT_LT(relit, 1.15 * sh2) << floor.dump(2);
  EXPECT_TRUE(metrics["sh_fits_scene"].get<bool>());
  EXPECT_NE(run.output.find("the destination photograph itself"), std::string::npos) << run.output;

  // A truth folder without its list: the error names the file.
  fs::create_directories(out / "empty");
  const relume::testing::CliResult missing =
      relume::testing::RunRelume("process " + (out / "session").string() + " --pipeline sh --out " +
                                 (out / "sh2").string() + " --set truth_dir=" + (out / "empty").string());
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find((out / "empty" / "rgb.txt").string()), std::string::npos) << missing.output;
  fs::remove_all(out);
}

}  // namespace
