#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core.hpp>
#include <random>

#include "calibration/calibration_profile.h"
#include "calibration/colorchecker_detect.h"
#include "calibration/colorchecker_fit.h"
#include "calibration/testing/synthetic_chart.h"
#include "core/error.h"

namespace relume::calibration {
namespace {

const ColorCheckerReference& Reference() {
  static const ColorCheckerReference reference =
      LoadColorCheckerReference("config/colorchecker/xrite_classic_2014_lab_d50.yaml");
  return reference;
}

// Sharma, Wu & Dalal (2005), table 1: L1 a1 b1 L2 a2 b2 and Delta E 2000.
constexpr double kSharmaPairs[34][7] = {
    {50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425},
    {50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615},
    {50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412},
    {50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000},
    {50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000},
    {50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000},
    {50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669},
    {50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195},
    {50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045},
    {50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045},
    {50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461},
    {50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065},
    {50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492},
    {50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977},
    {50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030},
    {50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535},
    {50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000},
    {50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000},
    {50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000},
    {50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000},
    {60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644},
    {63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630},
    {61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731},
    {35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645},
    {22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373},
    {36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146},
    {90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441},
    {90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381},
    {6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377},
    {2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082},
};

TEST(DeltaE2000Test, SharmaWuDalalPairs) {
  for (int i = 0; i < 34; ++i) {
    const double* p = kSharmaPairs[i];
    const Lab a(p[0], p[1], p[2]), b(p[3], p[4], p[5]);
    EXPECT_NEAR(DeltaE2000(a, b), p[6], 5e-5) << "pair " << i + 1;
    EXPECT_NEAR(DeltaE2000(b, a), p[6], 5e-5) << "pair " << i + 1 << " swapped";
  }
  EXPECT_EQ(DeltaE2000(Lab(50, 0, 0), Lab(50, 0, 0)), 0.0);
}

// A camera that mixes channels and sees a warm light: what gain + CCM must undo.
const cv::Matx33f kCameraFromLinear(0.80f, 0.15f, 0.05f, 0.10f, 0.80f, 0.10f, 0.03f, 0.17f, 0.80f);

testing::ChartSceneOptions Scene() {
  testing::ChartSceneOptions scene;
  scene.light = cv::Vec3d(1.15, 1.0, 0.75);
  return scene;
}

// Linear camera values (as from an HDR merge), with 1% multiplicative noise.
cv::Mat LinearChartImage(const testing::ChartSceneOptions& scene, double noise = 0.01) {
  cv::Mat linear = testing::MixChannels(testing::RenderChartRadiance(Reference(), scene), kCameraFromLinear);
  cv::Mat gauss(linear.size(), CV_32FC3);
  cv::RNG rng(5);
  rng.fill(gauss, cv::RNG::NORMAL, 0.0, noise);
  return linear.mul(cv::Scalar::all(1.0) + gauss);
}

// 8-bit sRGB-like preview for detection.
cv::Mat Preview(const cv::Mat& linear, double scale = 1.0) {
  cv::Mat out(linear.size(), CV_8UC3);
  for (int y = 0; y < linear.rows; ++y) {
    for (int x = 0; x < linear.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        out.at<cv::Vec3b>(y, x)[c] = cv::saturate_cast<std::uint8_t>(
            255.0 * SrgbEncode(std::clamp(scale * linear.at<cv::Vec3f>(y, x)[c], 0.0, 1.0)));
      }
    }
  }
  return out;
}

void ExpectCornersNear(const ChartLocation& loc, const testing::ChartSceneOptions& scene, double tol_px) {
  ASSERT_TRUE(loc.found) << loc.reason;
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT(cv::norm(loc.corners[k] - scene.corners[k]), tol_px) << loc.method << " corner " << k;
  }
}

TEST(ChartDetectTest, LatticeFallbackFindsTheChart) {
  const auto scene = Scene();
  const cv::Mat preview = Preview(LinearChartImage(scene));
  ChartDetectOptions options;
  options.detector = ChartDetector::kLattice;
  ExpectCornersNear(DetectColorChecker(preview, Reference(), options), scene, 4.0);
}

TEST(ChartDetectTest, LatticeFindsAChartUpsideDown) {
  auto scene = Scene();
  std::rotate(scene.corners.begin(), scene.corners.begin() + 2, scene.corners.end());
  const cv::Mat preview = Preview(LinearChartImage(scene));
  ChartDetectOptions options;
  options.detector = ChartDetector::kLattice;
  ExpectCornersNear(DetectColorChecker(preview, Reference(), options), scene, 4.0);
}

TEST(ChartDetectTest, AutoFindsTheChart) {
  const auto scene = Scene();
  const cv::Mat preview = Preview(LinearChartImage(scene));
  const ChartLocation loc = DetectColorChecker(preview, Reference());
  std::cout << "auto detection: " << loc.method << " (" << loc.reason << ")\n";
  ExpectCornersNear(loc, scene, 6.0);
}

TEST(ChartDetectTest, ManualCornersInAnyOrder) {
  const auto scene = Scene();
  const cv::Mat preview = Preview(LinearChartImage(scene));
  const std::vector<cv::Point2f> points = {scene.corners[2], scene.corners[0], scene.corners[3], scene.corners[1]};
  const ChartLocation loc = ChartFromCorners(points, preview, Reference());
  EXPECT_EQ(loc.method, "manual");
  ExpectCornersNear(loc, scene, 1e-3);
  EXPECT_THROW(ChartFromCorners({{0, 0}, {1, 1}, {2, 2}}, preview, Reference()), InvalidArgumentError);
  EXPECT_THROW(ChartFromCorners({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, preview, Reference()), InvalidArgumentError);
}

TEST(ChartDetectTest, NoChartIsReportedNotInvented) {
  cv::Mat noise(240, 320, CV_8UC3);
  cv::RNG(3).fill(noise, cv::RNG::UNIFORM, 0, 255);
  const ChartLocation loc = DetectColorChecker(noise, Reference());
  EXPECT_FALSE(loc.found);
  EXPECT_FALSE(loc.reason.empty());
}

ChartLocation TrueLocation(const testing::ChartSceneOptions& scene) {
  ChartLocation loc;
  loc.found = true;
  loc.corners = scene.corners;
  return loc;
}

TEST(ColorFitTest, LinearChartWithNoiseMeetsDeltaE1) {
  const auto scene = Scene();
  ChartImage image;
  image.values = LinearChartImage(scene);
  const auto patches = SamplePatches(image, TrueLocation(scene));
  for (const auto& p : patches) EXPECT_EQ(p.status, PatchStatus::kOk);
  const ColorFit fit = FitColorChecker(patches, Reference());
  ASSERT_TRUE(fit.summary.usable) << fit.summary.BriefReport();
  EXPECT_FALSE(fit.summary.low_confidence) << fit.summary.BriefReport();
  EXPECT_LE(fit.summary.mean_delta_e, 1.0) << fit.summary.BriefReport();
  std::cout << "linear chart, 1% noise: " << fit.summary.BriefReport() << "\n";
  EXPECT_EQ(fit.summary.patches_used, 24);
  // White preserving: the white patch maps exactly onto its reference.
  EXPECT_LT((fit.patches[18].corrected - Reference().patches[18].linear_rgb).norm(), 1e-9);
}

TEST(ColorFitTest, GammaEncodedChartLinearisedByTheNeutralGain) {
  // No response known: the gain through the six neutrals is the linearisation (Troccoli & Allen).
  const auto scene = Scene();
  ChartImage image;
  cv::Mat encoded = Preview(LinearChartImage(scene, 0.005));
  CameraImage camera;
  camera.pixels = encoded;
  image = ChartImageFromCamera(camera);
  const ColorFit fit = FitColorChecker(SamplePatches(image, TrueLocation(scene)), Reference());
  ASSERT_TRUE(fit.summary.usable);
  // Piecewise-linear between six knots approximates the sRGB curve to a few percent.
  EXPECT_LE(fit.summary.mean_delta_e, 3.0) << fit.summary.BriefReport();
  std::cout << "sRGB-encoded chart, gain only: " << fit.summary.BriefReport() << "\n";
}

TEST(ColorFitTest, WithoutWhitePreservingTheResidualIsNoLarger) {
  const auto scene = Scene();
  ChartImage image;
  image.values = LinearChartImage(scene);
  const auto patches = SamplePatches(image, TrueLocation(scene));
  ColorFitOptions free;
  free.white_preserving = false;
  const ColorFit a = FitColorChecker(patches, Reference(), free);
  const ColorFit b = FitColorChecker(patches, Reference());
  EXPECT_LE(a.summary.residual_rms, b.summary.residual_rms + 1e-12);
}

TEST(ColorFitTest, ClippedPatchIsRejectedAndNamed) {
  const auto scene = Scene();
  const cv::Mat linear = LinearChartImage(scene, 0.002);
  // Exposed so that the white patch (and only the brightest) clips at 8 bits.
  CameraImage camera;
  camera.pixels = Preview(linear, 1.25);
  const ChartImage image = ChartImageFromCamera(camera);
  const auto patches = SamplePatches(image, TrueLocation(scene));
  EXPECT_EQ(patches[18].status, PatchStatus::kSaturated);
  const ColorFit fit = FitColorChecker(patches, Reference());
  ASSERT_TRUE(fit.summary.usable);
  EXPECT_FALSE(fit.patches[18].used);
  EXPECT_NE(fit.summary.reason.find("white"), std::string::npos) << fit.summary.reason;
  EXPECT_TRUE(std::isfinite(fit.summary.mean_delta_e));
}

TEST(ColorFitTest, ChartHalfInShadowIsFlagged) {
  auto scene = Scene();
  scene.shadow_x = 245;  // the left half of the chart, patches of columns 0..2
  ChartImage image;
  image.values = LinearChartImage(scene);
  const auto patches = SamplePatches(image, TrueLocation(scene));
  const ColorFit fit = FitColorChecker(patches, Reference());
  ASSERT_TRUE(fit.summary.usable);
  EXPECT_TRUE(fit.summary.low_confidence);
  EXPECT_FALSE(fit.summary.reason.empty());
  EXPECT_TRUE(fit.ccm.allFinite());
  std::cout << "half in shadow: " << fit.summary.BriefReport() << "\n";
}

TEST(ColorFitTest, NearlySingularFitIsFlaggedAndFinite) {
  // Only the neutral patches usable: the colours span one direction.
  const auto scene = Scene();
  ChartImage image;
  image.values = LinearChartImage(scene);
  auto patches = SamplePatches(image, TrueLocation(scene));
  for (int k = 0; k < 18; ++k) patches[k].status = PatchStatus::kNonUniform;
  const ColorFit fit = FitColorChecker(patches, Reference());
  std::cout << "neutrals only: " << fit.summary.BriefReport() << "\n";
  ASSERT_TRUE(fit.summary.usable);
  EXPECT_TRUE(fit.summary.low_confidence);
  EXPECT_GT(fit.summary.condition, 100.0);
  EXPECT_TRUE(fit.ccm.allFinite());
  EXPECT_NE(fit.summary.reason.find("collinear"), std::string::npos);
  // Neutrals still map to neutrals.
  EXPECT_LT(fit.patches[20].delta_e, 1.0);
}

TEST(ColorFitTest, NoUsableNeutralIsUnusable) {
  const auto scene = Scene();
  ChartImage image;
  image.values = LinearChartImage(scene);
  auto patches = SamplePatches(image, TrueLocation(scene));
  for (int k = 18; k < 24; ++k) patches[k].status = PatchStatus::kSaturated;
  const ColorFit fit = FitColorChecker(patches, Reference());
  EXPECT_FALSE(fit.summary.usable);
  EXPECT_NE(fit.summary.reason.find("neutral"), std::string::npos);
}

TEST(CalibrationProfileTest, JsonRoundTripAndApply) {
  const auto scene = Scene();
  ChartImage image;
  image.values = LinearChartImage(scene, 0.0);
  const ColorFit fit = FitColorChecker(SamplePatches(image, TrueLocation(scene)), Reference());
  CalibrationProfile profile;
  profile.camera = "synthetic";
  profile.gain = fit.gain;
  profile.ccm = fit.ccm;
  profile.fit = fit.summary;
  profile.response = CameraResponse::Linear(3, 256, 0, 255);
  const std::string path = (std::filesystem::temp_directory_path() / "relume_profile_test.json").string();
  SaveProfile(profile, path);
  const CalibrationProfile loaded = LoadProfile(path);
  std::filesystem::remove(path);
  EXPECT_LT((loaded.ccm - profile.ccm).norm(), 1e-12);
  EXPECT_EQ(loaded.gain.x[1], profile.gain.x[1]);
  ASSERT_TRUE(loaded.response.has_value());
  EXPECT_NEAR(loaded.fit.mean_delta_e, fit.summary.mean_delta_e, 1e-12);
  // Each patch's Delta E 2000 (NaN where the fit did not use the patch) survives the file.
  ASSERT_EQ(fit.summary.patch_delta_e.size(), 24u);
  ASSERT_EQ(loaded.fit.patch_delta_e.size(), 24u);
  for (std::size_t k = 0; k < 24; ++k) {
    const double de = fit.summary.patch_delta_e[k];
    EXPECT_EQ(std::isfinite(de), fit.patches[k].used) << k;
    if (std::isfinite(de)) {
      EXPECT_DOUBLE_EQ(de, fit.patches[k].delta_e) << k;
      EXPECT_NEAR(loaded.fit.patch_delta_e[k], de, 1e-12) << k;
    } else {
      EXPECT_TRUE(std::isnan(loaded.fit.patch_delta_e[k])) << k;
    }
  }
  // Applied to the chart's radiance, the white patch comes out at its reference.
  RadianceImage radiance;
  radiance.pixels = image.values;
  const RadianceImage corrected = ApplyProfile(loaded, radiance);
  const cv::Point2f centre = ImageFromGrid(TrueLocation(scene), {0.5f, 3.5f});
  const cv::Vec3f white = corrected.pixels.at<cv::Vec3f>(static_cast<int>(centre.y), static_cast<int>(centre.x));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(white[c], Reference().patches[18].linear_rgb[c], 0.01);
}

TEST(CalibrationProfileTest, LoadNamesTheBadKey) {
  const std::string path = (std::filesystem::temp_directory_path() / "relume_profile_bad.json").string();
  {
    std::ofstream(path) << R"({"format": "relume-calibration-profile", "version": 1, "camera": "x",
      "gain_input": "radiance", "response": null, "gain": [], "ccm": [[1,0,0],[0,1,0],[0,0,1]]})";
  }
  try {
    LoadProfile(path);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "gain");
  }
  std::filesystem::remove(path);
  EXPECT_THROW(LoadProfile("/nonexistent/profile.json"), IoError);
}

}  // namespace
}  // namespace relume::calibration
