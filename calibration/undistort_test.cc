#include "calibration/undistort.h"

#include <gtest/gtest.h>

#include <cmath>

#include "calibration/testing/lens.h"
#include "core/error.h"

namespace relume::calibration {
namespace {

// A smooth pattern over the pinhole image plane (normalised coordinates).
double Pattern(double xn, double yn) {
  return 1.0 + 0.5 * std::sin(3.0 * xn) * std::cos(2.0 * yn);
}

// What a lens with `distortion` records of Pattern: each recorded pixel shows the point of the
// plane the lens bent onto it (found by inverting the distortion to 1e-12).
RadianceImage Photograph(const PinholeIntrinsics& k, const std::vector<double>& distortion) {
  const std::vector<cv::Point2d> normalised = testing::NormalisedPointsThroughLens(k, distortion);
  RadianceImage image = MakeRadianceImage(k.width, k.height, RadianceUnit::kRelative);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const cv::Point2d& n = normalised[static_cast<std::size_t>(v * k.width + u)];
      image.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f::all(static_cast<float>(Pattern(n.x, n.y)));
    }
  }
  return image;
}

// RMS relative error of `image` against the pattern a pinhole camera sees; `valid` counts the
// pixels compared (NaN pixels are not).
double PinholeError(const RadianceImage& image, const PinholeIntrinsics& k, int* valid) {
  double sum = 0.0;
  *valid = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const float got = image.pixels.at<cv::Vec3f>(v, u)[0];
      if (!std::isfinite(got)) continue;
      const double want = Pattern((u + 0.5 - k.cx) / k.fx, (v + 0.5 - k.cy) / k.fy);
      sum += (got / want - 1.0) * (got / want - 1.0);
      ++*valid;
    }
  }
  return *valid == 0 ? INFINITY : std::sqrt(sum / *valid);
}

const PinholeIntrinsics kCamera = PinholeIntrinsics::FromHorizontalFov(160, 120, 70.0 * M_PI / 180.0);

TEST(UndistortTest, BarrelDistortionIsUndoneAcrossTheFrame) {
  const std::vector<double> distortion{-0.25, 0.06, 0.002, -0.001, 0.0};
  const RadianceImage photo = Photograph(kCamera, distortion);
  int valid = 0;
  const double as_is = PinholeError(photo, kCamera, &valid);
  const Undistorter undistorter(kCamera, distortion);
  EXPECT_EQ(undistorter.outside_fraction(), 0.0);  // a barrel lens sees more than the pinhole
  const double undistorted = PinholeError(undistorter.Apply(photo), kCamera, &valid);
  EXPECT_GT(as_is, 0.02) << "the distortion must matter for this test to mean anything";
  EXPECT_LT(undistorted, 2e-3) << "as recorded: " << as_is;
  EXPECT_GT(valid, 160 * 120 * 99 / 100);  // only the outermost half pixel may blend with the border
}

TEST(UndistortTest, PincushionCornersComeFromOutsideTheFrameAndAreNaN) {
  const std::vector<double> distortion{0.3, 0.1, 0.0, 0.0};
  const RadianceImage photo = Photograph(kCamera, distortion);
  const Undistorter undistorter(kCamera, distortion);
  EXPECT_GT(undistorter.outside_fraction(), 0.01);
  const RadianceImage out = undistorter.Apply(photo);
  EXPECT_TRUE(std::isnan(out.pixels.at<cv::Vec3f>(0, 0)[0]));  // a corner
  int valid = 0;
  EXPECT_LT(PinholeError(out, kCamera, &valid), 2e-3);
  EXPECT_LT(valid, 160 * 120);
  EXPECT_NEAR(1.0 - static_cast<double>(valid) / (160 * 120), undistorter.outside_fraction(), 0.02);

  cv::Mat labels(120, 160, CV_8UC1, cv::Scalar(7));
  const cv::Mat mapped = undistorter.ApplyNearest(labels, 0);
  EXPECT_EQ(mapped.at<std::uint8_t>(0, 0), 0);
  EXPECT_EQ(mapped.at<std::uint8_t>(60, 80), 7);
}

TEST(UndistortTest, BadCoefficientsAndSizesAreNamed) {
  EXPECT_THROW(Undistorter(kCamera, {0.1, 0.0, 0.0}), InvalidArgumentError);
  EXPECT_THROW(Undistorter(kCamera, {0.1, NAN, 0.0, 0.0}), InvalidArgumentError);
  const Undistorter undistorter(kCamera, {0.1, 0.0, 0.0, 0.0});
  try {
    undistorter.Apply(MakeRadianceImage(80, 60, RadianceUnit::kRelative));
    FAIL() << "a frame of another size was undistorted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("80x60"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("160x120"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(HasDistortion({}));
  EXPECT_FALSE(HasDistortion({0.0, 0.0, 0.0, 0.0, 0.0}));
  EXPECT_TRUE(HasDistortion({0.0, 0.0, 1e-6, 0.0}));
}

}  // namespace
}  // namespace relume::calibration
