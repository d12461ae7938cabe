// Numerical stress across stages. Each case is an input the design card names as dangerous
// (near-zero denominators, normals covering a small part of the sphere, saturated and black
// pixels, NaN/Inf and holes in depth, the sun at the horizon and below it, polar sites, far
// dates, ill-conditioned colour fits, IRM ratios of near-zero radiance, albedo near 1 in
// radiosity), drawn at random with a fixed seed, and has a defined outcome: a correct result, a
// result flagged as low-confidence with the reason, or a clear error — never a silent NaN.
// Every test counts its cases; the last one prints the total.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <random>

#include "calibration/colorchecker_fit.h"
#include "calibration/hdr_merge.h"
#include "calibration/response.h"
#include "core/color.h"
#include "core/error.h"
#include "core/pinhole.h"
#include "core/site.h"
#include "core/sun/sun_position.h"
#include "processing/irm/irm.h"
#include "processing/normals.h"
#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/radiosity_solver.h"
#include "processing/relight.h"
#include "processing/sh.h"
#include "processing/sh_fit.h"

namespace relume {
namespace {

// Each test counts its cases and reports them (ctest runs every test in its own process).
class StressTest : public ::testing::Test {
 protected:
  void TearDown() override {
    RecordProperty("cases", g_cases);
    std::printf("stress %s: %d cases, no NaN or Inf where a value was promised\n",
                ::testing::UnitTest::GetInstance()->current_test_info()->name(), g_cases);
  }
  int g_cases = 0;
};

bool AllFinite(const cv::Mat& m) {
  cv::Mat f;
  m.convertTo(f, CV_64F);
  return cv::checkRange(f);
}

// Sun position: every latitude including the poles, heights from -400 m to 8000 m, years
// 1000-3000, instants at any time of day (so the sun is often at or below the horizon).
TEST_F(StressTest, SunPositionIsFiniteEverywhere) {
  std::mt19937_64 rng(20261122);
  std::uniform_real_distribution<double> lat(-90.0, 90.0), lon(-180.0, 180.0), height(-400.0, 8000.0);
  std::uniform_real_distribution<double> seconds(-30.0 * 365.25 * 86400 * 32, 30.0 * 365.25 * 86400 * 10);
  int below = 0;
  for (int i = 0; i < 3000; ++i, ++g_cases) {
    const double latitude = i % 50 == 0 ? (i % 100 == 0 ? 90.0 : -90.0) : lat(rng);
    const Site site = Site::FromDegrees(latitude, lon(rng), height(rng));
    const UtcTime t{std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(seconds(rng)))};
    const SunPosition p = ComputeSunPosition(site, t);
    ASSERT_TRUE(std::isfinite(p.elevation_rad) && std::isfinite(p.azimuth_rad) && std::isfinite(p.zenith_rad))
        << "lat " << latitude << " t " << FormatIso8601(t);
    EXPECT_LE(std::fabs(p.elevation_rad), M_PI / 2 + 1e-9);
    EXPECT_GE(p.azimuth_rad, 0.0);
    EXPECT_LT(p.azimuth_rad, 2 * M_PI);
    below += p.elevation_rad < 0.0;
  }
  EXPECT_GT(below, 1000) << "the sun below the horizon is part of the test";
}

// HDR merge: random brackets of 1-9 frames, exposure ratios up to 1e6, duplicated exposures,
// scenes with black and saturated regions. Outcome: a finite radiance everywhere; pixels
// saturated (or black) in every frame flagged as lower (upper) bounds.
TEST_F(StressTest, HdrMergeIsFiniteAndFlagsClippedPixels) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> frame_count(1, 9);
  std::uniform_real_distribution<double> log_t(-6.0, 0.0), u(0.0, 1.0);
  const calibration::CameraResponse response = calibration::CameraResponse::Linear(3, 256, 0, 255);
  for (int trial = 0; trial < 60; ++trial, ++g_cases) {
    const int n = frame_count(rng);
    const int w = 40, h = 30;
    cv::Mat radiance(h, w, CV_64FC3);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const double kind = u(rng);
        const double value = kind < 0.1 ? 0.0 : (kind > 0.9 ? 1e9 : std::pow(10.0, 8.0 * u(rng) - 2.0));
        radiance.at<cv::Vec3d>(y, x) = cv::Vec3d(value, value * u(rng), value);
      }
    }
    std::vector<CameraImage> frames;
    std::vector<double> times;
    for (int j = 0; j < n; ++j) {
      const double t = j > 0 && u(rng) < 0.2 ? times.back() : std::pow(10.0, log_t(rng));
      times.push_back(t);
      CameraImage image;
      image.pixels = cv::Mat(h, w, CV_8UC3);
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          for (int c = 0; c < 3; ++c) {
            image.pixels.at<cv::Vec3b>(y, x)[c] =
                static_cast<std::uint8_t>(std::clamp(radiance.at<cv::Vec3d>(y, x)[c] * t, 0.0, 255.0));
          }
        }
      }
      frames.push_back(image);
    }
    const calibration::HdrMergeResult merged = calibration::MergeHdr(frames, times, response);
    ASSERT_TRUE(AllFinite(merged.radiance.pixels)) << "trial " << trial << ": " << merged.summary.BriefReport();
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        bool saturated_everywhere = true;
        for (const CameraImage& f : frames) saturated_everywhere &= f.pixels.at<cv::Vec3b>(y, x)[0] >= 254;
        if (saturated_everywhere) {
          EXPECT_EQ(merged.status.at<std::uint8_t>(y, x) & calibration::kHdrSaturatedLowerBound,
                    calibration::kHdrSaturatedLowerBound);
        }
      }
    }
  }
}

// Response recovery from brackets that carry no information (all saturated, all black, one
// code): usable = false with a reason, and a curve that is still finite.
TEST_F(StressTest, ResponseRecoveryFromUselessBracketsSaysSo) {
  for (const int code : {0, 255, 128}) {
    ++g_cases;
    std::vector<CameraImage> frames(3);
    for (CameraImage& f : frames) f.pixels = cv::Mat(20, 20, CV_8UC3, cv::Scalar::all(code));
    const calibration::ResponseResult r = calibration::RecoverResponse(frames, {0.01, 0.1, 1.0});
    EXPECT_FALSE(r.summary.usable) << "code " << code;
    EXPECT_FALSE(r.summary.reason.empty());
    EXPECT_NE(r.summary.BriefReport().find("NOT usable"), std::string::npos);
    for (const auto& channel : r.response.inverse) {
      for (const double v : channel) ASSERT_TRUE(std::isfinite(v));
    }
  }
}

// The least-squares scale between images (Loscos eq. 3) with zero, NaN and empty inputs.
TEST_F(StressTest, ScaleFitWithDegenerateInputsIsFlagged) {
  const cv::Mat zero = cv::Mat::zeros(10, 10, CV_32FC3);
  cv::Mat ones(10, 10, CV_32FC3, cv::Scalar::all(1.0));
  cv::Mat nan(10, 10, CV_32FC3, cv::Scalar::all(std::nan("")));
  const cv::Mat none = cv::Mat::zeros(10, 10, CV_8UC1);
  for (const auto& [values, reference, mask] : std::vector<std::tuple<cv::Mat, cv::Mat, cv::Mat>>{
           {zero, ones, cv::Mat()}, {ones, zero, cv::Mat()}, {nan, ones, cv::Mat()}, {ones, ones, none}}) {
    ++g_cases;
    const calibration::ScaleFit fit = calibration::FitScaleFactor(values, reference, mask);
    EXPECT_TRUE(std::isfinite(fit.scale));
    EXPECT_TRUE(std::isfinite(fit.relative_rms));
    EXPECT_FALSE(fit.usable) << "degenerate input must not give a usable scale";
  }
}

// SH fits where the normals cover a small part of the sphere (down to one direction), with
// zero radiance, or no observations: finite coefficients, order reduced or usable = false.
TEST_F(StressTest, ShFitOnNarrowNormalsReducesOrderOrSaysSo) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const double spread : {0.0, 1e-6, 1e-3, 0.05, 0.3, 1.0}) {
    for (const bool dark : {false, true}) {
      ++g_cases;
      std::vector<processing::ShObservation> obs;
      for (int i = 0; i < 500; ++i) {
        processing::ShObservation o;
        o.normal = (Eigen::Vector3d(0, 0, -1) + spread * Eigen::Vector3d(g(rng), g(rng), g(rng))).normalized();
        o.radiance = dark ? Eigen::Vector3d::Zero() : Eigen::Vector3d::Constant(0.5 + 0.1 * o.normal.x());
        obs.push_back(o);
      }
      const processing::ShFitResult fit = processing::FitShKnownAlbedo(obs);
      ASSERT_TRUE(fit.light.allFinite()) << "spread " << spread;
      if (spread < 0.05) {
        EXPECT_TRUE(!fit.summary.usable || fit.summary.order_reduced || fit.summary.order_used < 2)
            << "spread " << spread << ": order 2 cannot be supported";
      }
      EXPECT_TRUE(std::isfinite(fit.summary.condition_number) || !fit.summary.usable);
    }
  }
  ++g_cases;
  const processing::ShFitResult empty = processing::FitShKnownAlbedo({});
  EXPECT_FALSE(empty.summary.usable);
  EXPECT_TRUE(empty.light.allFinite());
}

// Relighting with a near-zero or zero source irradiance: guarded, never divided; relit
// pixels finite.
TEST_F(StressTest, RelightNeverDividesByNearZeroIrradiance) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const double scale : {0.0, 1e-30, 1e-12, 1.0}) {
    ++g_cases;
    RadianceImage src = MakeRadianceImage(32, 24);
    cv::Mat normals(24, 32, CV_32FC3);
    for (int y = 0; y < 24; ++y) {
      for (int x = 0; x < 32; ++x) {
        src.pixels.at<cv::Vec3f>(y, x) = cv::Vec3f(0.5f, 0.4f, 0.3f);
        Eigen::Vector3d n(u(rng), u(rng), -1.0);
        n.normalize();
        normals.at<cv::Vec3f>(y, x) =
            cv::Vec3f(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
      }
    }
    processing::ShRgb src_light = processing::ShRgb::Zero();
    src_light.row(0).setConstant(scale);
    src_light(3, 0) = -0.9 * scale;  // makes some normals' irradiance ~0 or negative
    processing::ShRgb dst_light = processing::ShRgb::Zero();
    dst_light.row(0).setConstant(1.0);
    const processing::RelightResult r = processing::RelightSh(src, normals, cv::Mat(), src_light, dst_light);
    for (int y = 0; y < 24; ++y) {
      for (int x = 0; x < 32; ++x) {
        if (r.valid.at<std::uint8_t>(y, x) == 0) continue;
        const cv::Vec3f v = r.relit.pixels.at<cv::Vec3f>(y, x);
        ASSERT_TRUE(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2])) << "scale " << scale;
      }
    }
    if (scale == 0.0) {
      EXPECT_EQ(r.summary.relit_pixel_count, 0) << "nothing can be relit from no light";
    }
  }
}

// Normals from depth with NaN, +-Inf, zero (holes), negative values and spikes: every valid
// normal is a finite unit vector; invalid pixels are flagged, not guessed.
TEST_F(StressTest, NormalsFromBrokenDepthAreFiniteOrFlagged) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const PinholeIntrinsics intrinsics = PinholeIntrinsics::FromHorizontalFov(64, 48, 1.0);
  for (int trial = 0; trial < 20; ++trial, ++g_cases) {
    cv::Mat depth(48, 64, CV_32FC1);
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 64; ++x) {
        const double r = u(rng);
        float d = static_cast<float>(2.0 + 0.01 * x + 0.02 * y);
        if (r < 0.05)
          d = std::nanf("");
        else if (r < 0.07)
          d = std::numeric_limits<float>::infinity();
        else if (r < 0.08)
          d = -std::numeric_limits<float>::infinity();
        else if (r < 0.12)
          d = 0.0f;
        else if (r < 0.13)
          d = -1.0f;
        else if (r < 0.15)
          d *= 100.0f;
        depth.at<float>(y, x) = d;
      }
    }
    const processing::NormalMap map = processing::EstimateNormals(depth, intrinsics);
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 64; ++x) {
        if (map.valid.at<std::uint8_t>(y, x) == 0) continue;
        const cv::Vec3f n = map.normal_in_camera.at<cv::Vec3f>(y, x);
        ASSERT_TRUE(std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]));
        EXPECT_NEAR(std::sqrt(n.dot(n)), 1.0, 1e-4);
      }
    }
  }
}

// Colour fits from charts that do not constrain a 3x3 matrix: a camera whose channels are
// (nearly) linearly dependent, a chart of one grey, only the neutrals usable, random patches
// flagged, values at 1e-12 or 1e12, NaN and Inf medians on patches marked usable. Outcome: a
// finite gain and matrix always; `usable = false` with a reason, or a fit whose condition
// above the limit is flagged low-confidence; finite Delta E for every used patch.
TEST_F(StressTest, ColourFitsThatCannotBeConstrainedAreFlaggedAndFinite) {
  const ColorCheckerReference reference =
      LoadColorCheckerReference("config/colorchecker/xrite_classic_2014_lab_d50.yaml");
  std::mt19937_64 rng(20261201);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const calibration::ColorFitOptions options;
  int unusable = 0, low_confidence = 0;
  for (int k = 0; k < 300; ++k) {
    ++g_cases;
    const int kind = k % 6;
    Eigen::Matrix3d mix;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) mix(r, c) = (r == c ? 0.7 : 0.0) + 0.3 * u(rng);
    }
    if (kind == 0) mix.row(2) = 0.4 * mix.row(0) + 0.6 * mix.row(1);  // rank 2 camera
    const double scale = kind == 4 ? (u(rng) < 0.5 ? 1e-12 : 1e12) : 0.2 + u(rng);
    std::vector<calibration::PatchSample> patches(24);
    for (int i = 0; i < 24; ++i) {
      Eigen::Vector3d v = kind == 1 ? Eigen::Vector3d(Eigen::Vector3d::Constant(0.18))
                                    : Eigen::Vector3d(mix * reference.patches[i].linear_rgb);
      v = scale * v + 1e-6 * Eigen::Vector3d(u(rng), u(rng), u(rng));
      patches[i].median = cv::Vec3d(v[0], v[1], v[2]);
      if (kind == 2 && i < 18) patches[i].status = calibration::PatchStatus::kSaturated;
      if (kind == 3 && u(rng) < 0.6) patches[i].status = calibration::PatchStatus::kNonUniform;
    }
    if (kind == 5) {
      for (int j = 0; j < 3; ++j) {
        const int i = static_cast<int>(u(rng) * 24) % 24;
        patches[i].median[j % 3] = j == 0 ? std::nan("") : (j == 1 ? INFINITY : -INFINITY);
      }
    }
    const calibration::ColorFit fit = calibration::FitColorChecker(patches, reference, options);
    ASSERT_TRUE(fit.ccm.allFinite()) << "case " << k << ": " << fit.summary.BriefReport();
    for (int c = 0; c < 3; ++c) {
      for (std::size_t n = 0; n < fit.gain.x[c].size(); ++n) {
        ASSERT_TRUE(std::isfinite(fit.gain.x[c][n]) && std::isfinite(fit.gain.y[c][n])) << "case " << k;
      }
    }
    if (!fit.summary.usable) {
      ++unusable;
      EXPECT_FALSE(fit.summary.reason.empty()) << "case " << k;
      continue;
    }
    EXPECT_TRUE(std::isfinite(fit.summary.condition) && std::isfinite(fit.summary.mean_delta_e))
        << "case " << k << ": " << fit.summary.BriefReport();
    if (fit.summary.condition > options.max_condition) {
      EXPECT_TRUE(fit.summary.low_confidence) << "case " << k;
    }
    low_confidence += fit.summary.low_confidence ? 1 : 0;
    for (const calibration::PatchFit& patch : fit.patches) {
      if (!patch.used) continue;
      EXPECT_TRUE(patch.corrected.allFinite() && std::isfinite(patch.delta_e)) << "case " << k;
    }
  }
  std::printf("colour fits: %d unusable (with a reason), %d low-confidence, of 300\n", unusable, low_confidence);
}

// IRMs from samples whose radiance is zero, denormal, negative, NaN or Inf, with sun fractions
// anywhere in [0, 1] (and NaN), normals anywhere (and zero). Outcome: every measured bin holds a
// finite, positive ratio, empty bins are NaN, and a lookup is finite or NaN (the pixel is then
// left untouched as "no ratio"), never Inf.
TEST_F(StressTest, IrmsFromNearZeroRadianceHoldFiniteRatiosOrNone) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 1.0f);
  auto radiance = [&]() -> float {
    const float r = u(rng);
    if (r < 0.1f) return 0.0f;
    if (r < 0.15f) return 1e-38f;
    if (r < 0.2f) return -0.5f;
    if (r < 0.22f) return std::nanf("");
    if (r < 0.24f) return INFINITY;
    return 0.01f + 100.0f * u(rng);
  };
  for (int k = 0; k < 120; ++k) {
    ++g_cases;
    std::vector<irm::Sample> samples(static_cast<std::size_t>(u(rng) * 1500.0f));
    for (irm::Sample& s : samples) {
      s.normal = Eigen::Vector3f(g(rng), g(rng), g(rng));
      if (u(rng) < 0.02f) s.normal.setZero();
      s.source_rgb = Eigen::Vector3f(radiance(), radiance(), radiance());
      s.target_rgb = Eigen::Vector3f(radiance(), radiance(), radiance());
      const float r = u(rng);
      s.source_sun = r < 0.4f ? 1.0f : r < 0.7f ? 0.0f : r < 0.72f ? std::nanf("") : u(rng);
      s.target_sun = u(rng) < 0.5f ? 1.0f : u(rng);
      s.sky_view = u(rng) < 0.3f ? std::nanf("") : u(rng);
    }
    irm::IrmOptions options;
    options.bins = 8 + static_cast<int>(u(rng) * 32.0f);
    const Eigen::Vector3f sun_s = Eigen::Vector3f(g(rng), g(rng), std::abs(g(rng))).normalized();
    const Eigen::Vector3f sun_t = Eigen::Vector3f(g(rng), g(rng), std::abs(g(rng))).normalized();
    const irm::IrmSet set = irm::BuildIrms(samples, sun_s, sun_t, options);
    for (const irm::RatioMap& map : set.maps) {
      for (std::size_t b = 0; b < map.ratio.size(); ++b) {
        if (map.source.empty() || map.source[b] == 0) {
          ASSERT_TRUE(map.ratio[b].array().isNaN().all()) << "case " << k << ": empty bin " << b << " has a value";
        } else {
          ASSERT_TRUE(map.ratio[b].allFinite() && (map.ratio[b].array() >= 0.0f).all())
              << "case " << k << ": bin " << b << " = " << map.ratio[b].transpose() << " (source " << int{map.source[b]}
              << ")";
        }
      }
    }
    for (int q = 0; q < 200; ++q) {
      const Eigen::Vector3f n = Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized();
      const Eigen::Vector3f ratio = set.Ratio(n, u(rng), u(rng), u(rng) < 0.5f ? std::nanf("") : u(rng));
      ASSERT_FALSE(ratio.array().isInf().any()) << "case " << k << ": " << ratio.transpose();
      ASSERT_TRUE(ratio.allFinite() || ratio.array().isNaN().all()) << "case " << k << ": " << ratio.transpose();
    }
  }
}

// Radiosity in closed and open boxes with albedo near and at 1, emission or none, patch sizes
// from a quarter of the room to all of a wall. Outcome: radiosity finite and non-negative; a
// converged solve has its residual under the tolerance; albedo 1 in a closed room never claims
// convergence; no light gives exactly zero; the energy balance is finite.
TEST_F(StressTest, RadiosityWithAlbedoNearOneStopsWithAReasonAndStaysFinite) {
  std::mt19937_64 rng(1991);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double albedos[] = {0.0, 0.5, 0.9, 0.99, 0.999, 1.0};
  for (int k = 0; k < 18; ++k) {
    ++g_cases;
    const double albedo = albedos[k % 6];
    const bool closed = (k / 6) % 2 == 0;
    const bool lit = k < 12 || u(rng) < 0.5;
    radiosity::Mesh mesh;
    const int wall = mesh.AddMaterial({"wall", radiosity::Rgb::Constant(albedo), radiosity::Rgb::Zero()});
    const int lamp = mesh.AddMaterial(
        {"lamp", radiosity::Rgb::Constant(albedo), lit ? radiosity::Rgb(1.0, 2.0, 0.5) : radiosity::Rgb::Zero()});
    mesh.AddRoom({0, 0, 0}, {2, 2, 2}, /*floor=*/lamp, /*ceiling=*/wall, /*walls=*/wall);
    if (!closed) {  // without its ceiling (triangles 2 and 3) the room is a box open to the sky
      mesh.geometry.triangles.erase(mesh.geometry.triangles.begin() + 2, mesh.geometry.triangles.begin() + 4);
      mesh.geometry.material.erase(mesh.geometry.material.begin() + 2, mesh.geometry.material.begin() + 4);
    }
    radiosity::HierarchyOptions hierarchy_options;
    hierarchy_options.max_patch_edge_m = 0.5 + 1.5 * u(rng);
    const radiosity::PatchHierarchy h(mesh, hierarchy_options);
    const RayCaster caster(mesh.geometry);
    radiosity::RadiosityOptions options;
    options.max_iterations = 150;
    options.residual_tolerance = 1e-3;
    radiosity::RadiositySolver solver(h, caster, options);
    radiosity::RadiositySolution solution;
    const std::vector<radiosity::Rgb> direct(static_cast<std::size_t>(h.LeafCount()), radiosity::Rgb::Zero());
    const radiosity::RadiositySummary summary = solver.Solve(h.LeafAlbedo(), direct, h.LeafEmission(), &solution);
    bool any_light = false;
    for (const radiosity::Rgb& e : h.LeafEmission()) any_light = any_light || e.maxCoeff() > 0.0;
    for (const radiosity::Rgb& b : solution.radiosity) {
      ASSERT_TRUE(b.allFinite() && b.minCoeff() >= 0.0) << "case " << k << ": " << summary.BriefReport();
      if (!any_light) {
        ASSERT_EQ(b.maxCoeff(), 0.0) << "case " << k;
      }
    }
    EXPECT_TRUE(std::isfinite(summary.balance_error) && std::isfinite(summary.residual)) << summary.BriefReport();
    EXPECT_FALSE(summary.reason.empty()) << "case " << k;
    if (summary.converged && any_light) {
      EXPECT_LE(summary.residual, options.residual_tolerance) << summary.BriefReport();
    }
    if (closed && albedo == 1.0 && any_light) {
      EXPECT_FALSE(summary.converged) << "case " << k << ": " << summary.BriefReport();
    }
    if (!any_light) {
      EXPECT_EQ(summary.termination, radiosity::RadiosityTermination::kNoLight) << summary.BriefReport();
    }
  }
}

}  // namespace
}  // namespace relume
