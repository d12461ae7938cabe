// A camera's intrinsics from a series of images of a calibration board (Zhang's method through
// OpenCV's calibrateCamera): the focal lengths, the principal point and, on request, lens
// distortion, with the RMS reprojection error and each view's. Two boards:
//  - a printed chessboard of `inner_cols` x `inner_rows` inner corners and `square_m` squares,
//    which every view must show whole;
//  - a ChArUco board (a chessboard with an ArUco marker in each white square; OpenCV aruco):
//    every corner is identified by its neighbouring markers, so a view that shows part of the
//    board counts, and views can reach the image corners where distortion is largest.
//
// Conventions: intrinsics in core/pinhole.h's continuous pixel coordinates (pixel centres at
// u + 0.5): OpenCV's corner positions, which put centres at integers, are shifted by +0.5.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"

namespace cv::aruco {
class CharucoBoard;
}  // namespace cv::aruco

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

// A ChArUco board as OpenCV's aruco module makes it (CharucoBoard::create): `squares_x` x
// `squares_y` squares of `square_m`, the white ones holding markers of `marker_m` from
// `dictionary`, the first ids in order. DrawCharucoBoard prints it.
struct CharucoOptions {
  int squares_x = 7;
  int squares_y = 5;
  double square_m = 0.04;
  double marker_m = 0.03;
  std::string dictionary = "4x4_50";  // markers.h ArucoDictionaryNames()
  std::string distortion = "none";    // as ChessboardOptions
  int min_views = 3;
  int min_corners_per_view = 6;  // a view with fewer identified corners is not used
  bool IsValid(std::string* why) const;
};

// The board as an 8-bit grey image to print, `pixels_per_square` per square, no margin: pixel
// (u, v) covers [u, u+1) x [v, v+1) of the board, (0, 0) its top-left as printed.
cv::Mat DrawCharucoBoard(const CharucoOptions& options, int pixels_per_square);

// OpenCV's board for `options` (geometry and dictionary): what DrawCharucoBoard draws and what
// the ChArUco calibrations (here and rgbd_extrinsics.h) detect.
cv::Ptr<cv::aruco::CharucoBoard> MakeCharucoBoard(const CharucoOptions& options);

// `images`: 8-bit grey or RGB. Throws InvalidArgumentError when fewer than min_views images show
// at least min_corners_per_view identified corners (naming how many did), or the images differ
// in size. `views_without_board` lists the views not used.
IntrinsicsResult CalibrateIntrinsicsCharuco(const std::vector<cv::Mat>& images, const CharucoOptions& options);

// A camera frame as the 8-bit grey image corner detection takes: Bayer mosaics demosaiced,
// black and white levels applied, gamma 1/2.2 (corners do not care about the curve; the dark
// squares need the contrast).
cv::Mat ChessboardImage(const CameraImage& frame);

// `images`: 8-bit grey or RGB. Throws InvalidArgumentError when fewer than min_views images show
// the whole board (naming how many did and which did not), or the images differ in size.
IntrinsicsResult CalibrateIntrinsics(const std::vector<cv::Mat>& images, const ChessboardOptions& options);

}  // namespace relume::calibration
