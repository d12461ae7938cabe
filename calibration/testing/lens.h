// Test data for lens distortion (calibration/undistort.h): what a camera with OpenCV's
// distortion model (k1, k2, p1, p2[, k3]) records, made independently of the Undistorter
// (by inverting the distortion point by point with cv::undistortPoints to 1e-12).
#pragma once

#include <opencv2/core/mat.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/pinhole.h"

namespace relume::calibration::testing {

// For each pixel of a frame taken through the lens (row-major), the normalised pinhole
// coordinates (x/z, y/z) of the point it shows. Pixel centres at +0.5 (core/pinhole.h).
std::vector<cv::Point2d> NormalisedPointsThroughLens(const PinholeIntrinsics& k, const std::vector<double>& d);

// What the lens records of a pinhole frame (any cv::Mat type remap takes): each recorded pixel
// samples the pinhole frame bilinearly where the lens bent it from; beyond the pinhole frame's
// edge (a barrel lens sees more) the edge pixels are repeated.
// `interpolation`: cv::INTER_NEAREST for depth, which must not blend across silhouettes.
cv::Mat ThroughLens(const cv::Mat& pinhole, const PinholeIntrinsics& k, const std::vector<double>& d,
                    int interpolation = cv::INTER_LINEAR);

}  // namespace relume::calibration::testing
