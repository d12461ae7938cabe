// Pictures for calibration reports, drawn with OpenCV: response curves, the chart with its
// detected patches outlined, and measured-vs-reference swatches. All return 8-bit RGB.
#pragma once

#include <opencv2/core/mat.hpp>
#include <vector>

#include "calibration/colorchecker_detect.h"
#include "calibration/colorchecker_fit.h"
#include "calibration/response.h"

namespace relume::calibration {

// log2 of the inverse response against the code, one line per channel (R, G, B).
cv::Mat PlotResponse(const CameraResponse& response, int width = 640, int height = 400);

// The chart outline and each patch's sampled region: green = used, red = rejected.
cv::Mat DrawChart(const cv::Mat& rgb8, const ChartLocation& location, const std::vector<PatchSample>& patches);

// 6 x 4 swatches: each split into the corrected measurement (left) and the reference (right),
// sRGB-encoded; rejected patches crossed out.
cv::Mat DrawSwatches(const ColorFit& fit, const ColorCheckerReference& reference, int cell = 80);

// An 8-bit sRGB preview of linear values scaled so that the 99th percentile maps to 1.
cv::Mat PreviewLinear(const cv::Mat& linear_rgb);

}  // namespace relume::calibration
