#include "calibration/rgbd_extrinsics.h"

#include <Eigen/SVD>
#include <cmath>
#include <numbers>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "calibration/markers.h"
#include "core/error.h"

namespace relume::calibration {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// A plane n . x = d with |n| = 1 and d > 0 (n points away from the camera that sees it).
struct Plane {
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  double d = 0.0;
};

Plane Oriented(const Eigen::Vector3d& n, double d) {
  return d < 0.0 ? Plane{-n, -d} : Plane{n, d};
}

// The board seen by the colour camera: its plane and its outline (the board's outer corners,
// shrunk towards its centre by `margin`), both in the colour camera's frame.
struct ColourView {
  Plane plane;
  std::vector<Eigen::Vector3d> outline;
};

std::optional<ColourView> BoardInColour(const cv::Mat& image, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                        const PinholeIntrinsics& k, const RgbdExtrinsicsOptions& options) {
  cv::Mat grey = image;
  if (image.channels() != 1) cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(grey, board->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) return std::nullopt;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, board, corners, ids);
  if (static_cast<int>(ids.size()) < options.board.min_corners_per_view) return std::nullopt;
  std::vector<cv::Point3f> object;
  for (int id : ids) object.push_back(board->chessboardCorners[static_cast<std::size_t>(id)]);
  // OpenCV's pixel centres are at integers, relume's at +0.5.
  const cv::Matx33d camera(k.fx, 0, k.cx - 0.5, 0, k.fy, k.cy - 0.5, 0, 0, 1);
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, corners, camera, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE)) return std::nullopt;
  cv::solvePnPRefineLM(object, corners, camera, cv::noArray(), rvec, tvec);
  cv::Matx33d r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rotation;
  for (int i = 0; i < 9; ++i) rotation(i / 3, i % 3) = r(i / 3, i % 3);
  const Eigen::Vector3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  const Eigen::Vector3d n = rotation.col(2);
  ColourView view;
  view.plane = Oriented(n, n.dot(t));
  // The outer corners: one square beyond the inner corners' extent.
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (const cv::Point3f& p : board->chessboardCorners) {
    lo = lo.cwiseMin(Eigen::Vector2d(p.x, p.y));
    hi = hi.cwiseMax(Eigen::Vector2d(p.x, p.y));
  }
  lo -= Eigen::Vector2d::Constant(options.board.square_m);
  hi += Eigen::Vector2d::Constant(options.board.square_m);
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  const double keep = 1.0 - options.outline_margin_fraction;
  for (const Eigen::Vector2d& c : {lo, Eigen::Vector2d(hi.x(), lo.y()), hi, Eigen::Vector2d(lo.x(), hi.y())}) {
    const Eigen::Vector2d p = centre + keep * (c - centre);
    view.outline.push_back(rotation * Eigen::Vector3d(p.x(), p.y(), 0.0) + t);
  }
  return view;
}

// The plane of the depth points inside `outline` (colour frame) seen through `depth_from_colour`:
// RANSAC (deterministic) then least squares on the inliers. nullopt with fewer than 50 points or
// inliers.
std::optional<Plane> BoardInDepth(const cv::Mat& depth, const PinholeIntrinsics& k,
                                  const std::vector<Eigen::Vector3d>& outline,
                                  const Eigen::Isometry3d& depth_from_colour, double inlier_m, double* rms_m) {
  std::vector<cv::Point> polygon;
  for (const Eigen::Vector3d& c : outline) {
    const Eigen::Vector3d in_depth = depth_from_colour * c;
    if (!(in_depth.z() > 0.0)) return std::nullopt;
    const Eigen::Vector2d px = k.Project(in_depth);
    polygon.emplace_back(static_cast<int>(std::lround(px.x() - 0.5)), static_cast<int>(std::lround(px.y() - 0.5)));
  }
  cv::Mat mask = cv::Mat::zeros(depth.size(), CV_8UC1);
  cv::fillConvexPoly(mask, polygon, cv::Scalar(255));
  std::vector<Eigen::Vector3d> points;
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const float z = depth.at<float>(v, u);
      if (mask.at<std::uint8_t>(v, u) == 0 || !std::isfinite(z) || z <= 0.0f) continue;
      points.push_back(static_cast<double>(z) * k.Unproject({u + 0.5, v + 0.5}));
    }
  }
  if (points.size() < 50) return std::nullopt;
  std::mt19937 rng(1);
  std::uniform_int_distribution<std::size_t> pick(0, points.size() - 1);
  Plane best;
  std::size_t best_count = 0;
  for (int it = 0; it < 200; ++it) {
    const Eigen::Vector3d a = points[pick(rng)], b = points[pick(rng)], c = points[pick(rng)];
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    const Plane p = Oriented(n.normalized(), n.normalized().dot(a));
    std::size_t count = 0;
    for (const Eigen::Vector3d& x : points) count += std::abs(p.n.dot(x) - p.d) < inlier_m;
    if (count > best_count) {
      best_count = count;
      best = p;
    }
  }
  std::vector<Eigen::Vector3d> inliers;
  for (const Eigen::Vector3d& x : points) {
    if (std::abs(best.n.dot(x) - best.d) < inlier_m) inliers.push_back(x);
  }
  if (inliers.size() < 50) return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& x : inliers) mean += x;
  mean /= static_cast<double>(inliers.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& x : inliers) scatter += (x - mean) * (x - mean).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(scatter, Eigen::ComputeFullU);
  const Eigen::Vector3d n = svd.matrixU().col(2);
  const Plane plane = Oriented(n, n.dot(mean));
  double sum2 = 0.0;
  for (const Eigen::Vector3d& x : inliers) sum2 += std::pow(plane.n.dot(x) - plane.d, 2);
  *rms_m = std::sqrt(sum2 / static_cast<double>(inliers.size()));
  return plane;
}

}  // namespace

bool RgbdExtrinsicsOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!board.IsValid(why)) return false;
  if (min_views < 3) return fail("the extrinsics need at least 3 views of the board (min_views)");
  if (!(min_normal_spread_deg >= 0.0 && min_normal_spread_deg < 90.0))
    return fail("min_normal_spread_deg must be in [0, 90)");
  if (!(plane_inlier_m > 0.0)) return fail("plane_inlier_m must be positive");
  if (!(outline_margin_fraction >= 0.0 && outline_margin_fraction < 0.9))
    return fail("outline_margin_fraction must be in [0, 0.9)");
  if (iterations < 1) return fail("iterations must be at least 1");
  return true;
}

std::string RgbdExtrinsicsResult::Report() const {
  std::ostringstream out;
  out.precision(4);
  const Eigen::Vector3d t = color_from_depth.translation();
  const Eigen::AngleAxisd r(color_from_depth.linear());
  out << "colour from depth: translation (" << t.x() * 1e3 << ", " << t.y() * 1e3 << ", " << t.z() * 1e3
      << ") mm, rotation " << r.angle() * kRadToDeg << " deg; " << views_used.size() << " views, normals spread "
      << normal_spread_deg << " deg";
  if (!views_without_board.empty()) out << " (" << views_without_board.size() << " without a usable board)";
  return out.str();
}

RgbdExtrinsicsResult CalibrateRgbdExtrinsics(const std::vector<cv::Mat>& colour, const std::vector<cv::Mat>& depth,
                                             const PinholeIntrinsics& colour_intrinsics,
                                             const PinholeIntrinsics& depth_intrinsics,
                                             const Eigen::Isometry3d& initial, const RgbdExtrinsicsOptions& options) {
  ThrowIfInvalid(options, "RGB-D extrinsics options");
  if (colour.size() != depth.size()) {
    throw InvalidArgumentError("RGB-D extrinsics: " + std::to_string(colour.size()) + " colour frames but " +
                               std::to_string(depth.size()) + " depth frames; give them in pairs");
  }
  const cv::Ptr<cv::aruco::CharucoBoard> board = MakeCharucoBoard(options.board);
  RgbdExtrinsicsResult result;
  std::vector<ColourView> views;
  std::vector<int> view_index;
  for (std::size_t i = 0; i < colour.size(); ++i) {
    if (colour[i].depth() != CV_8U || colour[i].cols != colour_intrinsics.width ||
        colour[i].rows != colour_intrinsics.height) {
      throw InvalidArgumentError("RGB-D extrinsics: colour frame " + std::to_string(i) +
                                 " is not an 8-bit image of the colour camera's size");
    }
    if (depth[i].type() != CV_32FC1 || depth[i].cols != depth_intrinsics.width ||
        depth[i].rows != depth_intrinsics.height) {
      throw InvalidArgumentError("RGB-D extrinsics: depth frame " + std::to_string(i) +
                                 " is not float metres of the depth camera's size");
    }
    if (std::optional<ColourView> v = BoardInColour(colour[i], board, colour_intrinsics, options)) {
      views.push_back(*v);
      view_index.push_back(static_cast<int>(i));
    } else {
      result.views_without_board.push_back(static_cast<int>(i));
    }
  }
  Eigen::Isometry3d estimate = initial;
  std::vector<Plane> depth_planes;
  std::vector<int> used;
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    depth_planes.clear();
    used.clear();
    result.view_plane_rms_m.clear();
    const Eigen::Isometry3d depth_from_colour = estimate.inverse();
    for (std::size_t v = 0; v < views.size(); ++v) {
      double rms = 0.0;
      if (const std::optional<Plane> p =
              BoardInDepth(depth[static_cast<std::size_t>(view_index[v])], depth_intrinsics, views[v].outline,
                           depth_from_colour, options.plane_inlier_m, &rms)) {
        depth_planes.push_back(*p);
        used.push_back(static_cast<int>(v));
        result.view_plane_rms_m.push_back(rms);
      }
    }
    if (static_cast<int>(used.size()) < options.min_views) {
      throw InvalidArgumentError(
          "RGB-D extrinsics: only " + std::to_string(used.size()) + " of " + std::to_string(colour.size()) +
          " frame pairs show the " + std::to_string(options.board.squares_x) + "x" +
          std::to_string(options.board.squares_y) + "-square ChArUco board in colour and its plane in depth; " +
          std::to_string(options.min_views) + " are needed (check the board options)");
    }
    // The spread of the colour normals about their mean.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int v : used) mean += views[static_cast<std::size_t>(v)].plane.n;
    mean.normalize();
    double spread2 = 0.0;
    for (int v : used) {
      spread2 += std::pow(std::acos(std::clamp(views[static_cast<std::size_t>(v)].plane.n.dot(mean), -1.0, 1.0)), 2);
    }
    result.normal_spread_deg = std::sqrt(spread2 / static_cast<double>(used.size())) * kRadToDeg;
    if (result.normal_spread_deg < options.min_normal_spread_deg) {
      throw InvalidArgumentError("RGB-D extrinsics: the board's normals spread only " +
                                 std::to_string(result.normal_spread_deg) + " deg over the views (" +
                                 std::to_string(options.min_normal_spread_deg) +
                                 " needed): tilt the board differently in each view (left, right, up, down)");
    }
    // Rotation: colour normals from depth normals (Kabsch).
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    for (std::size_t j = 0; j < used.size(); ++j) {
      h += depth_planes[j].n * views[static_cast<std::size_t>(used[j])].plane.n.transpose();
    }
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
    fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
    const Eigen::Matrix3d rotation = svd.matrixV() * fix * svd.matrixU().transpose();
    // Translation: n_c . t = d_c - d_d per view, least squares.
    Eigen::MatrixXd a(static_cast<Eigen::Index>(used.size()), 3);
    Eigen::VectorXd b(static_cast<Eigen::Index>(used.size()));
    for (std::size_t j = 0; j < used.size(); ++j) {
      const Plane& c = views[static_cast<std::size_t>(used[j])].plane;
      a.row(static_cast<Eigen::Index>(j)) = c.n.transpose();
      b(static_cast<Eigen::Index>(j)) = c.d - depth_planes[j].d;
    }
    const Eigen::Vector3d t = a.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(b);
    estimate = Eigen::Isometry3d::Identity();
    estimate.linear() = rotation;
    estimate.translation() = t;
  }
  result.color_from_depth = estimate;
  result.view_normal_deg.clear();
  result.view_distance_m.clear();
  for (std::size_t j = 0; j < used.size(); ++j) {
    const Plane& c = views[static_cast<std::size_t>(used[j])].plane;
    const Eigen::Vector3d n = estimate.linear() * depth_planes[j].n;
    result.view_normal_deg.push_back(std::acos(std::clamp(n.dot(c.n), -1.0, 1.0)) * kRadToDeg);
    result.view_distance_m.push_back(c.n.dot(estimate.translation()) - (c.d - depth_planes[j].d));
    result.views_used.push_back(view_index[static_cast<std::size_t>(used[j])]);
  }
  for (std::size_t v = 0; v < views.size(); ++v) {
    if (std::find(used.begin(), used.end(), static_cast<int>(v)) == used.end()) {
      result.views_without_board.push_back(view_index[v]);
    }
  }
  std::sort(result.views_without_board.begin(), result.views_without_board.end());
  return result;
}

}  // namespace relume::calibration
