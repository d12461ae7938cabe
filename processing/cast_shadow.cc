#include "processing/cast_shadow.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/error.h"
#include "processing/depth_filter.h"

namespace relume::processing {
namespace {

constexpr double kY1 = 0.4886025119029199;  // sqrt(3 / (4 pi)): Y_1m = kY1 * (y, z, x)

double Luminance(const Eigen::Vector3d& rgb) {
  return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

void CheckInputs(const cv::Mat& depth_m, const cv::Mat& normals, const cv::Mat& mask,
                 const PinholeIntrinsics& intrinsics, const CastShadowOptions& options) {
  ThrowIfInvalid(options, "cast shadow options");
  const cv::Size size(intrinsics.width, intrinsics.height);
  if (depth_m.type() != CV_32FC1 || normals.type() != CV_32FC3 || mask.type() != CV_8UC1 || depth_m.size() != size ||
      normals.size() != size || mask.size() != size) {
    throw InvalidArgumentError("EstimateCastShadows: depth (CV_32FC1), normals (CV_32FC3) and mask (CV_8UC1) must be " +
                               std::to_string(size.width) + "x" + std::to_string(size.height));
  }
}

// Whether the ray from pixel (u, v) (depth z, normal n) toward d meets a surface the depth
// shows (the conventions at the top of cast_shadow.h).
bool Occluded(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics, int u, int v, double z,
              const Eigen::Vector3d& n, const Eigen::Vector3d& d, const CastShadowOptions& options) {
  const Eigen::Vector3d p = intrinsics.Unproject({u + 0.5, v + 0.5}) * z + options.surface_bias_m * n;
  const double step = std::max(options.max_distance_m, options.max_distance_per_m * z) / options.steps;
  for (int i = 1; i <= options.steps; ++i) {
    const Eigen::Vector3d q = p + (step * i) * d;
    if (q.z() <= 1e-3) return false;
    const Eigen::Vector2d image = intrinsics.Project(q);
    const int x = static_cast<int>(std::floor(image.x())), y = static_cast<int>(std::floor(image.y()));
    if (x < 0 || y < 0 || x >= intrinsics.width || y >= intrinsics.height) return false;
    const float surface = depth_m.at<float>(y, x);
    if (!std::isfinite(surface)) continue;
    const double in_front = q.z() - surface;
    const double thickness = std::max(options.thickness_m, options.thickness_per_m * q.z());
    if (in_front > options.depth_tolerance_m + options.depth_tolerance_per_m * q.z() && in_front < thickness)
      return true;
  }
  return false;
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace

bool CastShadowOptions::IsValid(std::string* why) const {
  const auto fail = [why](const char* reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!(max_distance_m > 0.0 && std::isfinite(max_distance_m))) return fail("max_distance_m must be positive");
  if (!(max_distance_per_m >= 0.0 && max_distance_per_m <= 100.0 && thickness_per_m >= 0.0 && thickness_per_m <= 100.0))
    return fail("max_distance_per_m and thickness_per_m must be within [0, 100]");
  if (!(min_facing >= 0.0 && min_facing < 1.0)) return fail("min_facing must be within [0, 1)");
  if (min_evidence_pixels < 1) return fail("min_evidence_pixels must be >= 1");
  if (steps < 1 || steps > 4096) return fail("steps must be within [1, 4096]");
  if (!(surface_bias_m >= 0.0 && depth_tolerance_m >= 0.0 && depth_tolerance_per_m >= 0.0))
    return fail("the bias and tolerances must not be negative");
  if (!(thickness_m > 0.0)) return fail("thickness_m must be positive");
  if (!(min_directional_share >= 0.0 && min_directional_share <= 1.0))
    return fail("min_directional_share must be within [0, 1]");
  return true;
}

std::string CastShadowEstimate::Describe() const {
  char text[256];
  if (!marched) {
    std::snprintf(text, sizeof(text), "the fitted light is diffuse (directional share %.0f %%): no cast shadows",
                  100.0 * directional_share);
  } else {
    std::snprintf(text, sizeof(text),
                  "%.1f %% of the %d pixels facing the main light (directional share %.0f %%) are shadowed by "
                  "surfaces the depth shows; the SH model misses %.1f %% of the irradiance (RMS)",
                  100.0 * shadowed_fraction(), facing_pixels, 100.0 * directional_share, 100.0 * removed_share_rms);
  }
  return text;
}

CastShadowEstimate EstimateCastShadows(const cv::Mat& depth_m, const cv::Mat& normals, const cv::Mat& mask,
                                       const PinholeIntrinsics& intrinsics, const ShRgb& light,
                                       const CastShadowOptions& options) {
  CheckInputs(depth_m, normals, mask, intrinsics, options);
  const cv::Size size(intrinsics.width, intrinsics.height);
  CastShadowEstimate out;
  // The main light: the order-1 band's luminance (coefficients 1, 2, 3 = y, z, x).
  Eigen::Vector3d band;
  for (int axis = 0; axis < 3; ++axis) {
    const int k = axis == 0 ? 3 : axis == 1 ? 1 : 2;
    band[axis] = Luminance(light.row(k).transpose());
  }
  const double norm = band.norm();
  if (!(norm > 0.0)) return out;
  const Eigen::Vector3d d = band / norm;
  out.light_direction = d;
  out.directional_irradiance = norm / kY1;
  const auto sh_luminance = [&](const Eigen::Vector3d& n) { return Luminance(ShIrradiance(light, n)); };
  const double at_light = sh_luminance(d);
  out.directional_share = at_light > 0.0 ? std::min(1.0, out.directional_irradiance / at_light) : 0.0;
  if (out.directional_share < options.min_directional_share) return out;
  out.marched = true;

  double removed_squared = 0.0;
  std::int64_t assessed = 0;
  for (int v = 0; v < size.height; ++v) {
    const float* z_row = depth_m.ptr<float>(v);
    const auto* n_row = normals.ptr<cv::Vec3f>(v);
    const std::uint8_t* m_row = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < size.width; ++u) {
      if (m_row[u] == 0 || !IsDepthValid(z_row[u])) continue;
      const Eigen::Vector3d n(n_row[u][0], n_row[u][1], n_row[u][2]);
      if (!n.allFinite()) continue;
      ++assessed;
      const double facing = n.dot(d);
      if (facing <= 0.0) continue;
      ++out.facing_pixels;
      if (!Occluded(depth_m, intrinsics, u, v, z_row[u], n, d, options)) continue;
      ++out.shadowed_pixels;
      const double e = sh_luminance(n);
      const double removed = e > 0.0 ? std::min(1.0, out.directional_irradiance * facing / e) : 1.0;
      removed_squared += removed * removed;
    }
  }
  out.removed_share_rms = assessed > 0 ? std::sqrt(removed_squared / static_cast<double>(assessed)) : 0.0;
  return out;
}

std::string DirectionalShadowEvidence::Describe() const {
  char text[320];
  if (facing_pixels == 0) return "no pixel faces the light";
  std::snprintf(text, sizeof(text),
                "%.1f %% of the %d pixels facing the light are shadowed by surfaces the depth shows",
                100.0 * shadowed_fraction(), facing_pixels);
  std::string out = text;
  if (std::isfinite(contrast)) {
    std::snprintf(text, sizeof(text), "; the lit ones are %.2fx as bright as the shadowed ones (median luminance)",
                  contrast);
    out += text;
  } else {
    out += "; too few on one side to compare their brightness";
  }
  return out;
}

DirectionalShadowEvidence EstimateShadowsToward(const cv::Mat& depth_m, const cv::Mat& normals, const cv::Mat& mask,
                                                const PinholeIntrinsics& intrinsics, const Eigen::Vector3d& direction,
                                                const RadianceImage& radiance, const CastShadowOptions& options) {
  CheckInputs(depth_m, normals, mask, intrinsics, options);
  if (radiance.pixels.type() != CV_32FC3 || radiance.pixels.size() != depth_m.size()) {
    throw InvalidArgumentError("EstimateShadowsToward: the radiance must be CV_32FC3 and the depth's size");
  }
  if (!(direction.norm() > 0.0) || !direction.allFinite()) {
    throw InvalidArgumentError("EstimateShadowsToward: the light's direction must be a non-zero vector");
  }
  DirectionalShadowEvidence out;
  const Eigen::Vector3d d = direction.normalized();
  out.direction = d;
  std::vector<double> lit, shadowed;
  for (int v = 0; v < intrinsics.height; ++v) {
    const float* z_row = depth_m.ptr<float>(v);
    const auto* n_row = normals.ptr<cv::Vec3f>(v);
    const std::uint8_t* m_row = mask.ptr<std::uint8_t>(v);
    const auto* c_row = radiance.pixels.ptr<cv::Vec3f>(v);
    for (int u = 0; u < intrinsics.width; ++u) {
      if (m_row[u] == 0 || !IsDepthValid(z_row[u])) continue;
      const Eigen::Vector3d n(n_row[u][0], n_row[u][1], n_row[u][2]);
      const Eigen::Vector3d rgb(c_row[u][0], c_row[u][1], c_row[u][2]);
      if (!n.allFinite() || !rgb.allFinite() || n.dot(d) < options.min_facing) continue;
      ++out.facing_pixels;
      const bool occluded = Occluded(depth_m, intrinsics, u, v, z_row[u], n, d, options);
      out.shadowed_pixels += occluded ? 1 : 0;
      (occluded ? shadowed : lit).push_back(Luminance(rgb));
    }
  }
  const int min_pixels = options.min_evidence_pixels;
  if (static_cast<int>(lit.size()) >= min_pixels && static_cast<int>(shadowed.size()) >= min_pixels) {
    out.lit_luminance_median = Median(std::move(lit));
    out.shadowed_luminance_median = Median(std::move(shadowed));
    if (out.shadowed_luminance_median > 0.0) out.contrast = out.lit_luminance_median / out.shadowed_luminance_median;
  }
  return out;
}

}  // namespace relume::processing
