#include "processing/irm/sky_shape.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"

namespace relume::irm {

namespace {

struct SkyPixel {
  float z;
  Eigen::Vector3f rgb;
};

// Least squares of L = a + b z per channel over `pixels`; false when the system is singular.
bool FitLine(const std::vector<SkyPixel>& pixels, Eigen::Vector3f* a, Eigen::Vector3f* b) {
  double n = 0, sz = 0, szz = 0;
  Eigen::Vector3d sl = Eigen::Vector3d::Zero(), szl = Eigen::Vector3d::Zero();
  for (const SkyPixel& p : pixels) {
    n += 1;
    sz += p.z;
    szz += static_cast<double>(p.z) * p.z;
    sl += p.rgb.cast<double>();
    szl += static_cast<double>(p.z) * p.rgb.cast<double>();
  }
  const double det = n * szz - sz * sz;
  if (!(det > 1e-12 * n * n)) return false;
  for (int c = 0; c < 3; ++c) {
    (*b)[c] = static_cast<float>((n * szl[c] - sz * sl[c]) / det);
    (*a)[c] = static_cast<float>((sl[c] - (*b)[c] * sz) / n);
  }
  return true;
}

double RelativeResidual(const SkyPixel& p, const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    const double model = a[c] + b[c] * p.z;
    sum += std::pow((p.rgb[c] - model) / std::max(1e-30, std::abs(model)), 2);
  }
  return sum / 3.0;
}

}  // namespace

bool SkyShapeOptions::IsValid(std::string* why) const {
  const auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (max_rays < 1) return fail("max_rays must be >= 1");
  if (!(sun_exclusion_rad >= 0.0f && sun_exclusion_rad < 3.2f)) return fail("sun_exclusion_rad must be in [0, pi]");
  if (!(min_elevation_span_rad > 0.0f && min_elevation_span_rad < 1.58f))
    return fail("min_elevation_span_rad must be in (0, pi/2]");
  if (min_pixels < 2) return fail("min_pixels must be >= 2");
  if (!(trim_fraction >= 0.0f && trim_fraction < 0.5f)) return fail("trim_fraction must be in [0, 0.5)");
  if (!(max_abs_gradient > 0.0f)) return fail("max_abs_gradient must be > 0");
  return true;
}

SkyShape FitSkyShape(const RayCaster& caster, const cv::Mat& radiance, const PinholeCamera& camera, const cv::Mat& mask,
                     const Eigen::Vector3f& sun_dir, const SkyShapeOptions& options) {
  ThrowIfInvalid(options, "sky shape options");
  const int w = camera.intrinsics.width, h = camera.intrinsics.height;
  if (radiance.type() != CV_32FC3 || radiance.cols != w || radiance.rows != h) {
    throw InvalidArgumentError("sky shape: the radiance must be CV_32FC3 of the camera's size");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != radiance.size())) {
    throw InvalidArgumentError("sky shape: the mask must be CV_8UC1 of the image's size");
  }
  SkyShape shape;
  // A grid of pixels, every `step`-th in both directions, whole rows at a time (packet rays).
  const int step = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(w) * h / options.max_rays))));
  const Eigen::Vector3f sun = sun_dir.normalized();
  const float cos_exclusion = std::cos(options.sun_exclusion_rad);
  const Eigen::Matrix3f rotation = camera.world_from_camera.linear().cast<float>();
  std::vector<SkyPixel> pixels;
  std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(w));
  for (int y = step / 2; y < h; y += step) {
    caster.IntersectCameraRow(camera, y, 0, w, hits);
    const auto* row = radiance.ptr<cv::Vec3f>(y);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
    for (int x = step / 2; x < w; x += step) {
      if (hits[static_cast<std::size_t>(x)].valid || (m != nullptr && m[x] != 0)) continue;
      const Eigen::Vector3f d = (rotation * camera.intrinsics.Unproject({x + 0.5, y + 0.5}).cast<float>()).normalized();
      if (d.z() <= 0.0f || d.dot(sun) >= cos_exclusion) continue;
      const Eigen::Vector3f rgb(row[x][0], row[x][1], row[x][2]);
      if (!rgb.allFinite() || !(rgb.minCoeff() > 0.0f)) continue;
      pixels.push_back({d.z(), rgb});
    }
  }
  shape.pixels = static_cast<int>(pixels.size());
  if (shape.pixels < options.min_pixels) {
    shape.reason = "too few sky pixels (" + std::to_string(shape.pixels) + " < " + std::to_string(options.min_pixels) +
                   "): the sky is taken as uniform";
    return shape;
  }
  const auto [lo, hi] =
      std::minmax_element(pixels.begin(), pixels.end(), [](const SkyPixel& p, const SkyPixel& q) { return p.z < q.z; });
  shape.min_elevation_rad = std::asin(std::clamp(lo->z, -1.0f, 1.0f));
  shape.max_elevation_rad = std::asin(std::clamp(hi->z, -1.0f, 1.0f));
  if (shape.max_elevation_rad - shape.min_elevation_rad < options.min_elevation_span_rad) {
    shape.reason = "the sky seen spans too little elevation to measure its gradient: the sky is taken as uniform";
    return shape;
  }
  Eigen::Vector3f a, b;
  if (!FitLine(pixels, &a, &b)) {
    shape.reason = "singular sky fit: the sky is taken as uniform";
    return shape;
  }
  if (options.trim_fraction > 0.0f) {
    std::vector<std::pair<double, std::size_t>> residual;
    residual.reserve(pixels.size());
    for (std::size_t i = 0; i < pixels.size(); ++i) residual.emplace_back(RelativeResidual(pixels[i], a, b), i);
    const std::size_t keep = pixels.size() - static_cast<std::size_t>(options.trim_fraction * pixels.size());
    std::nth_element(residual.begin(), residual.begin() + static_cast<std::ptrdiff_t>(keep - 1), residual.end());
    std::vector<SkyPixel> kept;
    kept.reserve(keep);
    for (std::size_t i = 0; i < keep; ++i) kept.push_back(pixels[residual[i].second]);
    if (!FitLine(kept, &a, &b)) {
      shape.reason = "singular sky fit: the sky is taken as uniform";
      return shape;
    }
    pixels = std::move(kept);
  }
  double sum = 0;
  for (const SkyPixel& p : pixels) sum += RelativeResidual(p, a, b);
  shape.rms_relative_residual = std::sqrt(sum / pixels.size());
  if (!(a.minCoeff() > 0.0f)) {
    shape.reason = "the fitted sky is not positive at the horizon: the sky is taken as uniform";
    return shape;
  }
  const Eigen::Vector3f g = b.cwiseQuotient(a);
  // At the zenith the model gives a (1 + g); a sky darker than black there is no sky.
  if (!g.allFinite() || g.cwiseAbs().maxCoeff() > options.max_abs_gradient ||
      !((Eigen::Vector3f::Ones() + g).minCoeff() > 0.0f)) {
    shape.reason = "the fitted gradient is not a plausible sky: the sky is taken as uniform";
    return shape;
  }
  shape.measured = true;
  shape.gradient = g;
  shape.horizon = a;
  return shape;
}

}  // namespace relume::irm
