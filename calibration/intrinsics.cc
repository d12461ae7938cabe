#include "calibration/intrinsics.h"

#include <algorithm>
#include <cmath>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "calibration/demosaic.h"
#include "calibration/markers.h"
#include "core/error.h"

namespace relume::calibration {
namespace {

// OpenCV's calibrateCamera flags for relume's distortion choice.
int DistortionFlags(const std::string& distortion) {
  if (distortion == "none") return cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3;
  if (distortion == "radial") return cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3;
  return 0;
}

void FillIntrinsics(const cv::Mat& k, const cv::Mat& dist, const cv::Size& size, const std::string& distortion,
                    IntrinsicsResult* result) {
  result->intrinsics.width = size.width;
  result->intrinsics.height = size.height;
  result->intrinsics.fx = k.at<double>(0, 0);
  result->intrinsics.fy = k.at<double>(1, 1);
  result->intrinsics.cx = k.at<double>(0, 2) + 0.5;  // OpenCV's pixel centres are at integers
  result->intrinsics.cy = k.at<double>(1, 2) + 0.5;
  if (distortion != "none") {
    for (int i = 0; i < 5; ++i) result->distortion.push_back(dist.at<double>(i));
  }
}

// Image `index` of a series as 8-bit grey, checked against the first one's size.
cv::Mat BoardGrey(const cv::Mat& image, const cv::Size& size, int index, const char* board) {
  if (image.size() != size) {
    throw InvalidArgumentError(std::string(board) + " image " + std::to_string(index) + " is " +
                               std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", the first " +
                               std::to_string(size.width) + "x" + std::to_string(size.height) +
                               ": one camera, one size");
  }
  if (image.depth() != CV_8U) throw InvalidArgumentError(std::string(board) + " images must have 8-bit samples");
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  return grey;
}

}  // namespace

cv::Mat ChessboardImage(const CameraImage& frame) {
  ThrowIfInvalid(frame, "chessboard frame");
  const bool mosaic = frame.layout != ColorLayout::kMono && frame.layout != ColorLayout::kRgb;
  const CameraImage image = mosaic ? DemosaicBilinear(frame) : frame;
  cv::Mat grey;
  if (image.pixels.channels() == 1) {
    image.pixels.convertTo(grey, CV_32F);
  } else {
    cv::Mat as_float;
    image.pixels.convertTo(as_float, CV_32F);
    cv::cvtColor(as_float, grey, cv::COLOR_RGB2GRAY);
  }
  const float black = static_cast<float>(image.black_level);
  const float range = static_cast<float>(std::max(1, image.white_level - image.black_level));
  cv::Mat out(grey.size(), CV_8UC1);
  for (int y = 0; y < grey.rows; ++y) {
    for (int x = 0; x < grey.cols; ++x) {
      const float v = std::clamp((grey.at<float>(y, x) - black) / range, 0.0f, 1.0f);
      out.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(std::lround(255.0f * std::pow(v, 1.0f / 2.2f)));
    }
  }
  return out;
}

bool ChessboardOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (inner_cols < 3 || inner_rows < 3 || inner_cols > 100 || inner_rows > 100) {
    return fail("the board needs 3..100 inner corners each way");
  }
  if (inner_cols == inner_rows)
    return fail("a square board's orientation is ambiguous: use unequal inner corner counts");
  if (!(square_m > 0.0 && square_m < 10.0)) return fail("square size must be in (0, 10) m");
  if (distortion != "none" && distortion != "radial" && distortion != "full") {
    return fail("distortion must be none, radial or full");
  }
  if (min_views < 3) return fail("intrinsics need at least 3 views of the board");
  return true;
}

std::string IntrinsicsResult::Report() const {
  std::ostringstream out;
  out.precision(4);
  out << "fx " << intrinsics.fx << ", fy " << intrinsics.fy << ", cx " << intrinsics.cx << ", cy " << intrinsics.cy
      << " px (" << intrinsics.width << "x" << intrinsics.height << ")";
  if (!distortion.empty()) {
    out << ", distortion";
    for (double d : distortion) out << " " << d;
  }
  out << "; RMS " << rms_px << " px over " << views_used.size() << " views";
  if (!views_without_board.empty()) out << " (" << views_without_board.size() << " without the whole board)";
  return out.str();
}

IntrinsicsResult CalibrateIntrinsics(const std::vector<cv::Mat>& images, const ChessboardOptions& options) {
  ThrowIfInvalid(options, "chessboard options");
  if (images.empty()) throw InvalidArgumentError("no images of the chessboard");
  const cv::Size pattern(options.inner_cols, options.inner_rows);
  std::vector<cv::Point3f> board;
  for (int r = 0; r < options.inner_rows; ++r) {
    for (int c = 0; c < options.inner_cols; ++c) {
      board.emplace_back(static_cast<float>(c * options.square_m), static_cast<float>(r * options.square_m), 0.0f);
    }
  }
  IntrinsicsResult result;
  const cv::Size size = images.front().size();
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (int i = 0; i < static_cast<int>(images.size()); ++i) {
    const cv::Mat grey = BoardGrey(images[static_cast<std::size_t>(i)], size, i, "chessboard");
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(grey, pattern, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      result.views_without_board.push_back(i);
      continue;
    }
    cv::cornerSubPix(grey, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
    image_points.push_back(corners);
    object_points.push_back(board);
    result.views_used.push_back(i);
  }
  if (static_cast<int>(image_points.size()) < options.min_views) {
    throw InvalidArgumentError("only " + std::to_string(image_points.size()) + " of " + std::to_string(images.size()) +
                               " images show the whole " + std::to_string(options.inner_cols) + "x" +
                               std::to_string(options.inner_rows) + " inner-corner board; intrinsics need " +
                               std::to_string(options.min_views) + " (check --board: inner corners, not squares)");
  }
  cv::Mat k = cv::Mat::eye(3, 3, CV_64F), dist = cv::Mat::zeros(5, 1, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  std::vector<double> intrinsic_sd, extrinsic_sd, per_view;
  result.rms_px = cv::calibrateCamera(object_points, image_points, size, k, dist, rvecs, tvecs, intrinsic_sd,
                                      extrinsic_sd, per_view, DistortionFlags(options.distortion));
  result.view_rms_px = per_view;
  FillIntrinsics(k, dist, size, options.distortion, &result);
  return result;
}

bool CharucoOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (squares_x < 3 || squares_y < 3 || squares_x > 100 || squares_y > 100) {
    return fail("the board needs 3..100 squares each way");
  }
  if (!(square_m > 0.0 && square_m < 10.0)) return fail("square size must be in (0, 10) m");
  if (!(marker_m > 0.0 && marker_m < square_m)) return fail("the marker must be smaller than the square");
  const std::vector<std::string> names = ArucoDictionaryNames();
  if (std::find(names.begin(), names.end(), dictionary) == names.end()) {
    return fail("no ArUco dictionary named '" + dictionary + "'");
  }
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(ArucoDictionaryId(dictionary));
  const int markers = squares_x * squares_y / 2;
  if (markers > dict->bytesList.rows) {
    return fail("a " + std::to_string(squares_x) + "x" + std::to_string(squares_y) + " board needs " +
                std::to_string(markers) + " markers and dictionary " + dictionary + " has " +
                std::to_string(dict->bytesList.rows));
  }
  if (distortion != "none" && distortion != "radial" && distortion != "full") {
    return fail("distortion must be none, radial or full");
  }
  if (min_views < 3) return fail("intrinsics need at least 3 views of the board");
  if (min_corners_per_view < 4) return fail("a view needs at least 4 corners (min_corners_per_view)");
  return true;
}

cv::Ptr<cv::aruco::CharucoBoard> MakeCharucoBoard(const CharucoOptions& options) {
  return cv::aruco::CharucoBoard::create(options.squares_x, options.squares_y, static_cast<float>(options.square_m),
                                         static_cast<float>(options.marker_m),
                                         cv::aruco::getPredefinedDictionary(ArucoDictionaryId(options.dictionary)));
}

cv::Mat DrawCharucoBoard(const CharucoOptions& options, int pixels_per_square) {
  ThrowIfInvalid(options, "ChArUco board");
  if (pixels_per_square < 8) throw InvalidArgumentError("DrawCharucoBoard: give at least 8 pixels per square");
  cv::Mat image;
  MakeCharucoBoard(options)->draw(
      cv::Size(options.squares_x * pixels_per_square, options.squares_y * pixels_per_square), image, 0, 1);
  return image;
}

IntrinsicsResult CalibrateIntrinsicsCharuco(const std::vector<cv::Mat>& images, const CharucoOptions& options) {
  ThrowIfInvalid(options, "ChArUco options");
  if (images.empty()) throw InvalidArgumentError("no images of the ChArUco board");
  const cv::Ptr<cv::aruco::CharucoBoard> board = MakeCharucoBoard(options);
  cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  IntrinsicsResult result;
  const cv::Size size = images.front().size();
  std::vector<cv::Mat> corners_per_view, ids_per_view;
  for (int i = 0; i < static_cast<int>(images.size()); ++i) {
    const cv::Mat grey = BoardGrey(images[static_cast<std::size_t>(i)], size, i, "ChArUco");
    std::vector<std::vector<cv::Point2f>> marker_corners;
    std::vector<int> marker_ids;
    cv::aruco::detectMarkers(grey, board->dictionary, marker_corners, marker_ids, params);
    cv::Mat corners, ids;
    if (!marker_ids.empty()) {
      cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, board, corners, ids);
    }
    if (ids.total() < static_cast<std::size_t>(options.min_corners_per_view)) {
      result.views_without_board.push_back(i);
      continue;
    }
    corners_per_view.push_back(corners);
    ids_per_view.push_back(ids);
    result.views_used.push_back(i);
  }
  if (static_cast<int>(corners_per_view.size()) < options.min_views) {
    throw InvalidArgumentError(
        "only " + std::to_string(corners_per_view.size()) + " of " + std::to_string(images.size()) + " images show " +
        std::to_string(options.min_corners_per_view) + " or more corners of the " + std::to_string(options.squares_x) +
        "x" + std::to_string(options.squares_y) + "-square ChArUco board (dictionary " + options.dictionary +
        "); intrinsics need " + std::to_string(options.min_views) +
        " (check --charuco: squares, not corners, and --dictionary)");
  }
  cv::Mat k = cv::Mat::eye(3, 3, CV_64F), dist = cv::Mat::zeros(5, 1, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  std::vector<double> intrinsic_sd, extrinsic_sd, per_view;
  result.rms_px =
      cv::aruco::calibrateCameraCharuco(corners_per_view, ids_per_view, board, size, k, dist, rvecs, tvecs,
                                        intrinsic_sd, extrinsic_sd, per_view, DistortionFlags(options.distortion));
  result.view_rms_px = per_view;
  FillIntrinsics(k, dist, size, options.distortion, &result);
  return result;
}

}  // namespace relume::calibration
