// A camera's intrinsics from a series of chessboard images (Zhang's method through OpenCV's
// calibrateCamera): the focal lengths, the principal point and, on request, lens distortion,
// with the RMS reprojection error and each view's. The board is a printed chessboard of
// `inner_cols` x `inner_rows` inner corners and `square_m` squares, seen from several angles.
//
// Conventions: intrinsics in core/pinhole.h's continuous pixel coordinates (pixel centres at
// u + 0.5): OpenCV's corner positions, which put centres at integers, are shifted by +0.5.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"

namespace relume::calibration {

struct ChessboardOptions {
  int inner_cols = 9;
  int inner_rows = 6;
  double square_m = 0.025;
  // "none": a pinhole camera (relume's pipelines take pinhole images; the RMS says whether the
  // lens needs more); "radial": k1, k2; "full": k1, k2, p1, p2, k3.
  std::string distortion = "none";
  int min_views = 3;
  bool IsValid(std::string* why) const;
};

struct IntrinsicsResult {
  PinholeIntrinsics intrinsics;
  std::vector<double> distortion;  // empty for "none"; else OpenCV's order (k1, k2, p1, p2, k3)
  double rms_px = 0.0;
  std::vector<double> view_rms_px;  // per image that showed the whole board
  std::vector<int> views_used;      // indices into the images given
  std::vector<int> views_without_board;
  std::string Report() const;
};

// A camera frame as the 8-bit grey image corner detection takes: Bayer mosaics demosaiced,
// black and white levels applied, gamma 1/2.2 (corners do not care about the curve; the dark
// squares need the contrast).
cv::Mat ChessboardImage(const CameraImage& frame);

// `images`: 8-bit grey or RGB. Throws InvalidArgumentError when fewer than min_views images show
// the whole board (naming how many did and which did not), or the images differ in size.
IntrinsicsResult CalibrateIntrinsics(const std::vector<cv::Mat>& images, const ChessboardOptions& options);

}  // namespace relume::calibration
