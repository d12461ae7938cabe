// A synthetic photograph of a ColorChecker for tests: the chart's reference reflectances
// (core/color.h) under a light, seen through a homography, encoded by a camera response with
// noise. Test data for relume_calibration only, to be replaced by the sim camera model.
//
// Chart geometry (units of one patch pitch): the patch grid spans [0, 6] x [0, 4]; patch
// (col, row) is the square [col + g/2, col + 1 - g/2] x [row + g/2, row + 1 - g/2] (g = gap);
// the chart body (dark, reflectance 0.03) extends `border` beyond the grid.
#pragma once

#include <array>
#include <opencv2/core/mat.hpp>

#include "calibration/testing/synthetic_bracket.h"
#include "core/color.h"
#include "core/image.h"

namespace relume::calibration::testing {

struct ChartSceneOptions {
  int width = 480;
  int height = 360;
  // Image positions of the grid corners: grid (0,0), (6,0), (6,4), (0,4).
  std::array<cv::Point2f, 4> corners = {cv::Point2f(80, 70), cv::Point2f(410, 90), cv::Point2f(400, 300),
                                        cv::Point2f(90, 290)};
  double gap = 0.2;
  double border = 0.35;
  double background = 0.35;        // reflectance of the surface behind the chart
  cv::Vec3d light{1.0, 1.0, 1.0};  // illuminant colour (linear RGB multiplier)
  // A shadow over the image columns x < shadow_x (factor shadow_factor); none when < 0.
  double shadow_x = -1.0;
  double shadow_factor = 0.25;
};

// Linear radiance (CV_32FC3): reflectance * light * shadow, 4x4 supersampled.
cv::Mat RenderChartRadiance(const ColorCheckerReference& chart, const ChartSceneOptions& options);

// Mixes the channels like a real camera's spectral sensitivities do (rows sum to 1): what a
// colour correction matrix has to undo.
cv::Mat MixChannels(const cv::Mat& radiance, const cv::Matx33f& camera_from_linear);

}  // namespace relume::calibration::testing
