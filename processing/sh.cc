#include "processing/sh.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <string>

#include "core/error.h"

namespace relume::processing {
namespace {

constexpr double kY0 = 0.28209479177387814;   // 1 / (2 sqrt(pi))
constexpr double kY1 = 0.4886025119029199;    // sqrt(3 / (4 pi))
constexpr double kY2 = 1.0925484305920792;    // sqrt(15 / (4 pi))
constexpr double kY20 = 0.31539156525252005;  // sqrt(5 / (16 pi))
constexpr double kY22 = 0.5462742152960396;   // sqrt(15 / (16 pi))

void CheckEnvironmentMap(const RadianceImage& latlong) {
  if (latlong.pixels.empty() || latlong.pixels.type() != CV_32FC3) {
    throw InvalidArgumentError("environment map: need a non-empty RGB float (CV_32FC3) lat-long image");
  }
  if (!cv::checkRange(latlong.pixels)) {
    throw InvalidArgumentError("environment map: contains NaN or Inf; fill the missing directions first");
  }
}

}  // namespace

ShVector ShBasis(const Eigen::Vector3d& d) {
  const double x = d.x(), y = d.y(), z = d.z();
  ShVector b;
  b << kY0, kY1 * y, kY1 * z, kY1 * x, kY2 * x * y, kY2 * y * z, kY20 * (3.0 * z * z - 1.0), kY2 * x * z,
      kY22 * (x * x - y * y);
  return b;
}

ShVector ShIrradianceBasis(const Eigen::Vector3d& n) {
  ShVector b = ShBasis(n);
  b(0) *= ShBandFactor(0);
  b.segment<3>(1) *= ShBandFactor(1);
  b.segment<5>(4) *= ShBandFactor(2);
  return b;
}

Eigen::Vector3d ShIrradiance(const ShRgb& light, const Eigen::Vector3d& n) {
  return light.transpose() * ShIrradianceBasis(n);
}

Eigen::Vector3d ShRadiance(const ShRgb& light, const Eigen::Vector3d& w) {
  return light.transpose() * ShBasis(w);
}

Eigen::Vector3d ShMeanIrradiance(const ShRgb& light) {
  return light.row(0).transpose() * (ShBandFactor(0) * kY0);
}

ShRgb TruncateSh(const ShRgb& light, int order) {
  RELUME_CHECK(order >= 0 && order <= 2);
  ShRgb out = light;
  out.bottomRows(kShCount - ShCountForOrder(order)).setZero();
  return out;
}

Eigen::Vector3d LatLongDirection(double u, double v, int width, int height) {
  const double theta = std::numbers::pi * v / height;
  const double phi = 2.0 * std::numbers::pi * u / width;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

double LatLongPixelSolidAngle(int row, int width, int height) {
  const double theta0 = std::numbers::pi * row / height;
  const double theta1 = std::numbers::pi * (row + 1) / height;
  return 2.0 * std::numbers::pi / width * (std::cos(theta0) - std::cos(theta1));
}

ShRgb ProjectEnvironmentMap(const RadianceImage& latlong, const Eigen::Matrix3d& sh_from_map) {
  CheckEnvironmentMap(latlong);
  const int width = latlong.width(), height = latlong.height();
  ShRgb light = ShRgb::Zero();
  for (int v = 0; v < height; ++v) {
    const double solid_angle = LatLongPixelSolidAngle(v, width, height);
    const cv::Vec3f* row = latlong.pixels.ptr<cv::Vec3f>(v);
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d w = sh_from_map * LatLongDirection(u + 0.5, v + 0.5, width, height);
      const Eigen::Vector3d radiance(row[u][0], row[u][1], row[u][2]);
      light += (ShBasis(w) * solid_angle) * radiance.transpose();
    }
  }
  return light;
}

Eigen::Vector3d IntegrateIrradiance(const RadianceImage& latlong, const Eigen::Matrix3d& sh_from_map,
                                    const Eigen::Vector3d& n) {
  CheckEnvironmentMap(latlong);
  const int width = latlong.width(), height = latlong.height();
  const Eigen::Vector3d n_in_map = sh_from_map.transpose() * n;
  Eigen::Vector3d irradiance = Eigen::Vector3d::Zero();
  for (int v = 0; v < height; ++v) {
    const double solid_angle = LatLongPixelSolidAngle(v, width, height);
    const cv::Vec3f* row = latlong.pixels.ptr<cv::Vec3f>(v);
    for (int u = 0; u < width; ++u) {
      const double cosine = LatLongDirection(u + 0.5, v + 0.5, width, height).dot(n_in_map);
      if (cosine <= 0.0) continue;
      irradiance += Eigen::Vector3d(row[u][0], row[u][1], row[u][2]) * (cosine * solid_angle);
    }
  }
  return irradiance;
}

}  // namespace relume::processing
