#include "processing/sh_display.h"

#include "core/error.h"

namespace relume::processing {
namespace {

Eigen::Vector3d Evaluate(const ShRgb& light, const Eigen::Vector3d& w, ShDisplayQuantity quantity) {
  return quantity == ShDisplayQuantity::kRadiance ? ShRadiance(light, w) : ShIrradiance(light, w);
}

void Store(const Eigen::Vector3d& value, cv::Vec3f* pixel) {
  *pixel = cv::Vec3f(static_cast<float>(value(0)), static_cast<float>(value(1)), static_cast<float>(value(2)));
}

}  // namespace

cv::Mat ShToLatLong(const ShRgb& light, int width, int height, ShDisplayQuantity quantity,
                    const Eigen::Matrix3d& sh_from_map) {
  if (width < 1 || height < 1) throw InvalidArgumentError("SH lat-long: width and height must be positive");
  cv::Mat out(height, width, CV_32FC3);
  for (int v = 0; v < height; ++v) {
    cv::Vec3f* row = out.ptr<cv::Vec3f>(v);
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d w = sh_from_map * LatLongDirection(u + 0.5, v + 0.5, width, height);
      Store(Evaluate(light, w, quantity), &row[u]);
    }
  }
  return out;
}

bool CubeCrossDirection(int x, int y, int face_size, Eigen::Vector3d* direction) {
  const int fx = x / face_size, fy = y / face_size;
  const double s = 2.0 * ((x % face_size) + 0.5) / face_size - 1.0;
  const double t = 2.0 * ((y % face_size) + 0.5) / face_size - 1.0;
  Eigen::Vector3d d;
  if (fy == 1 && fx == 0)
    d = {-1, t, s};
  else if (fy == 1 && fx == 1)
    d = {s, t, 1};
  else if (fy == 1 && fx == 2)
    d = {1, t, -s};
  else if (fy == 1 && fx == 3)
    d = {-s, t, -1};
  else if (fy == 0 && fx == 1)
    d = {s, -1, t};
  else if (fy == 2 && fx == 1)
    d = {s, 1, -t};
  else
    return false;
  *direction = d.normalized();
  return true;
}

cv::Mat ShToCubeCross(const ShRgb& light, int face_size, ShDisplayQuantity quantity) {
  if (face_size < 1) throw InvalidArgumentError("SH cube map: face_size must be positive");
  cv::Mat out = cv::Mat::zeros(3 * face_size, 4 * face_size, CV_32FC3);
  for (int y = 0; y < out.rows; ++y) {
    cv::Vec3f* row = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < out.cols; ++x) {
      Eigen::Vector3d w;
      if (CubeCrossDirection(x, y, face_size, &w)) Store(Evaluate(light, w, quantity), &row[x]);
    }
  }
  return out;
}

}  // namespace relume::processing
