#include "calibration/camera_pose.h"

#include <Eigen/SVD>
#include <charconv>
#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <sstream>

#include "core/error.h"
#include "core/frames.h"
#include "core/input_file.h"

namespace relume::calibration {

namespace {

cv::Mat CameraMatrix(const PinholeIntrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0);
}

}  // namespace

bool ParseCsvNumber(const std::string& text, double* value) {
  std::size_t begin = text.find_first_not_of(" \t");
  std::size_t end = text.find_last_not_of(" \t\r");
  if (begin == std::string::npos) return false;
  const char* first = text.data() + begin;
  const char* last = text.data() + end + 1;
  const auto result = std::from_chars(first, last, *value);
  return result.ec == std::errc() && result.ptr == last && std::isfinite(*value);
}

bool CameraPoseOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!(ransac_threshold_px > 0.0 && ransac_threshold_px <= 1000.0))
    return fail("ransac threshold must be in (0, 1000] px");
  if (min_points < 4) return fail("a pose needs at least 4 ground control points");
  if (!distortion.empty() && distortion.size() != 4 && distortion.size() != 5 && distortion.size() != 8) {
    return fail("distortion takes 4, 5 or 8 coefficients (OpenCV's model)");
  }
  return true;
}

std::string CameraPoseResult::Report(const std::vector<GroundControlPoint>& points) const {
  std::ostringstream out;
  out.precision(3);
  out << std::fixed;
  for (std::size_t i = 0; i < points.size() && i < residual_px.size(); ++i) {
    out << "  " << points[i].name << ": " << residual_px[i] << " px" << (inlier[i] ? "" : "  (outlier, not used)")
        << "\n";
  }
  out << "  RMS over " << inliers << " inliers: " << rms_px << " px\n";
  return out.str();
}

CameraPoseResult EstimateCameraPose(const std::vector<GroundControlPoint>& points, const PinholeIntrinsics& intrinsics,
                                    const CameraPoseOptions& options) {
  ThrowIfInvalid(options, "camera pose options");
  ThrowIfInvalid(intrinsics, "camera intrinsics");
  const int n = static_cast<int>(points.size());
  if (n < options.min_points) {
    throw InvalidArgumentError("a camera pose needs at least " + std::to_string(options.min_points) +
                               " ground control points; " + std::to_string(n) + " given");
  }
  // Degenerate layouts: all points on one line leave the rotation about it free.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const GroundControlPoint& p : points) mean += p.enu_m;
  mean /= n;
  Eigen::MatrixXd centred(n, 3);
  for (int i = 0; i < n; ++i) centred.row(i) = (points[static_cast<std::size_t>(i)].enu_m - mean).transpose();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred);
  if (!(svd.singularValues()(1) > 1e-6 * std::max(1.0, svd.singularValues()(0)))) {
    throw InvalidArgumentError(
        "the ground control points lie on one line; the pose needs points spread over a "
        "plane or in depth");
  }
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (const GroundControlPoint& p : points) {
    object.emplace_back(p.enu_m.x() - mean.x(), p.enu_m.y() - mean.y(), p.enu_m.z() - mean.z());
    image.emplace_back(p.pixel.x(), p.pixel.y());
  }
  const cv::Mat k = CameraMatrix(intrinsics);
  const cv::Mat dist = options.distortion.empty() ? cv::Mat() : cv::Mat(options.distortion, true);
  cv::Mat rvec, tvec;
  std::vector<int> inlier_ids;
  const bool found = cv::solvePnPRansac(object, image, k, dist, rvec, tvec, false, 500, options.ransac_threshold_px,
                                        0.999, inlier_ids, cv::SOLVEPNP_SQPNP);
  if (!found || static_cast<int>(inlier_ids.size()) < options.min_points) {
    throw InvalidArgumentError("no camera pose explains " + std::to_string(options.min_points) +
                               " or more of the ground control points within " +
                               std::to_string(options.ransac_threshold_px) +
                               " px: check the points' pixels, their coordinates' frame (enu, utm, wgs84) and the "
                               "intrinsics");
  }
  std::vector<cv::Point3d> in_object;
  std::vector<cv::Point2d> in_image;
  for (int i : inlier_ids) {
    in_object.push_back(object[static_cast<std::size_t>(i)]);
    in_image.push_back(image[static_cast<std::size_t>(i)]);
  }
  cv::solvePnPRefineLM(in_object, in_image, k, dist, rvec, tvec);

  cv::Mat r_cv;
  cv::Rodrigues(rvec, r_cv);
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  cv::cv2eigen(r_cv, r);
  cv::cv2eigen(tvec, t);
  Eigen::Isometry3d camera_from_centred = Eigen::Isometry3d::Identity();
  camera_from_centred.linear() = r;
  camera_from_centred.translation() = t;
  CameraPoseResult result;
  result.world_from_camera = Eigen::Translation3d(mean) * camera_from_centred.inverse();

  std::vector<cv::Point2d> projected;
  cv::projectPoints(object, rvec, tvec, k, dist, projected);
  result.residual_px.resize(points.size());
  result.inlier.assign(points.size(), false);
  for (int i : inlier_ids) result.inlier[static_cast<std::size_t>(i)] = true;
  double sum2 = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d in_camera = camera_from_centred * Eigen::Vector3d(object[i].x, object[i].y, object[i].z);
    if (!(in_camera.z() > 0.0)) {
      result.inlier[i] = false;
      result.residual_px[i] = std::numeric_limits<double>::infinity();
      continue;
    }
    result.residual_px[i] = std::hypot(projected[i].x - image[i].x, projected[i].y - image[i].y);
    if (result.inlier[i]) {
      sum2 += result.residual_px[i] * result.residual_px[i];
      ++result.inliers;
    }
  }
  if (result.inliers < options.min_points) {
    throw InvalidArgumentError("the best pose puts ground control points behind the camera; check their coordinates");
  }
  result.rms_px = std::sqrt(sum2 / result.inliers);
  return result;
}

SurveyFrame::SurveyFrame(const std::string& frame, const Site& site, int zone) : frame_(frame), enu_(site) {
  if (frame != "enu" && frame != "utm" && frame != "wgs84") {
    throw InvalidArgumentError("survey frame '" + frame + "' is not one of enu, utm, wgs84");
  }
  if (frame == "utm") grid_.emplace(site, zone > 0 ? std::optional<int>(zone) : std::nullopt);
}

Eigen::Vector3d SurveyFrame::ToEnu(const Eigen::Vector3d& abc) const {
  if (frame_ == "enu") return abc;
  if (frame_ == "utm") return enu_.EnuFromGeodetic(grid_->GeodeticFromGrid(abc));
  return enu_.EnuFromGeodetic(Site::FromDegrees(abc.x(), abc.y(), abc.z()));
}

std::vector<GroundControlPoint> LoadGcpFile(const std::string& path, const std::string& frame, const Site& site,
                                            int zone) {
  const SurveyFrame survey(frame, site, zone);
  std::ifstream in = OpenInputFile(path);
  std::vector<GroundControlPoint> points;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) cells.push_back(cell);
    double v[5];
    const bool numeric = cells.size() == 6 && ParseCsvNumber(cells[1], &v[0]) && ParseCsvNumber(cells[2], &v[1]) &&
                         ParseCsvNumber(cells[3], &v[2]) && ParseCsvNumber(cells[4], &v[3]) &&
                         ParseCsvNumber(cells[5], &v[4]);
    if (!numeric) {
      if (points.empty() && number == 1) continue;  // the header
      throw ConfigError(path, number, "gcp", "expected name,u,v,a,b,c with numbers (a, b, c in " + frame + ")");
    }
    GroundControlPoint p;
    p.name = cells[0];
    p.pixel = {v[0], v[1]};
    try {
      p.enu_m = survey.ToEnu(Eigen::Vector3d(v[2], v[3], v[4]));
    } catch (const InvalidArgumentError& e) {
      throw ConfigError(path, number, "gcp", e.what());
    }
    points.push_back(p);
  }
  if (points.empty()) throw ConfigError(path, number, "gcp", "no ground control points in the file");
  return points;
}

}  // namespace relume::calibration
