#include "processing/relight.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/parallel.h"

namespace relume::processing {
namespace {

// ShBasis (processing/sh.h) in single precision, for the per-pixel loop.
Eigen::Matrix<float, kShCount, 1> BasisF(const Eigen::Vector3f& d) {
  const float x = d.x(), y = d.y(), z = d.z();
  Eigen::Matrix<float, kShCount, 1> b;
  b << 0.28209479f, 0.48860251f * y, 0.48860251f * z, 0.48860251f * x, 1.09254843f * x * y, 1.09254843f * y * z,
      0.31539157f * (3.0f * z * z - 1.0f), 1.09254843f * x * z, 0.54627422f * (x * x - y * y);
  return b;
}

// The ratio filter RelightOptions asks for: ratio_* or, for normals from noisy depth, noisy_ratio_*.
struct RatioFilter {
  int radius_px = 0;
  double spatial_sigma_px = 1.0;
  double range_sigma = 1.0;
};
RatioFilter RatioFilterOf(const RelightOptions& options) {
  if (options.normals_from_noisy_depth) {
    return {options.noisy_ratio_radius_px, options.noisy_ratio_spatial_sigma_px, options.noisy_ratio_range_sigma};
  }
  return {options.ratio_radius_px, options.ratio_spatial_sigma_px, options.ratio_range_sigma};
}

// The joint bilateral filter of the ratio image: over the pixels `valid` marks, weights
// exp(-d^2 / 2 s^2) exp(-dg^2 / 2 r^2) with g = ln(luminance of the source). Range weights come
// from a table up to 4 r; beyond it they are taken as 0.
cv::Mat FilterRatio(const cv::Mat& ratio, const cv::Mat& valid, const cv::Mat& source, const RatioFilter& filter) {
  const int radius = filter.radius_px;
  const cv::Size size = ratio.size();
  cv::Mat guide(size, CV_32FC1, cv::Scalar(0.0f));
  for (int y = 0; y < size.height; ++y) {
    const cv::Vec3f* s = source.ptr<cv::Vec3f>(y);
    const unsigned char* v = valid.ptr<unsigned char>(y);
    float* g = guide.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      if (v[x]) g[x] = std::log(std::max(1e-30f, (s[x][0] + s[x][1] + s[x][2]) / 3.0f));
    }
  }
  const int side = 2 * radius + 1;
  std::vector<float> spatial(static_cast<std::size_t>(side * side));
  const double s2 = 2.0 * filter.spatial_sigma_px * filter.spatial_sigma_px;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      spatial[static_cast<std::size_t>((dy + radius) * side + dx + radius)] =
          static_cast<float>(std::exp(-(dx * dx + dy * dy) / s2));
    }
  }
  constexpr int kRangeSteps = 256;  // the table spans 4 range sigmas
  std::vector<float> range(kRangeSteps);
  for (int i = 0; i < kRangeSteps; ++i) {
    const double u = 4.0 * i / kRangeSteps;
    range[static_cast<std::size_t>(i)] = static_cast<float>(std::exp(-0.5 * u * u));
  }
  const float to_step = static_cast<float>(kRangeSteps / (4.0 * filter.range_sigma));

  cv::Mat out = ratio.clone();
  // Rows in parallel: each writes its own output row only (identical for any thread count).
  ParallelForEach(0, size.height, [&](std::int64_t row) {
    const int y = static_cast<int>(row);
    const unsigned char* v = valid.ptr<unsigned char>(y);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < size.width; ++x) {
      if (!v[x]) continue;
      const float g0 = guide.at<float>(y, x);
      float sum[3] = {0.0f, 0.0f, 0.0f}, weight = 0.0f;
      for (int yy = std::max(0, y - radius); yy <= std::min(size.height - 1, y + radius); ++yy) {
        const unsigned char* vv = valid.ptr<unsigned char>(yy);
        const float* g = guide.ptr<float>(yy);
        const cv::Vec3f* r = ratio.ptr<cv::Vec3f>(yy);
        const int w_row = (yy - y + radius) * side + radius - x;  // spatial[w_row + xx]
        for (int xx = std::max(0, x - radius); xx <= std::min(size.width - 1, x + radius); ++xx) {
          if (!vv[xx]) continue;
          const int step = static_cast<int>(std::abs(g[xx] - g0) * to_step);
          if (step >= kRangeSteps) continue;
          const float w = spatial[static_cast<std::size_t>(w_row + xx)] * range[static_cast<std::size_t>(step)];
          for (int c = 0; c < 3; ++c) sum[c] += w * r[xx][c];
          weight += w;
        }
      }
      for (int c = 0; c < 3; ++c) o[x][c] = sum[c] / weight;  // the centre's own weight is 1
    }
  });
  return out;
}

// The shading check (RelightOptions::max_albedo_deviation). `albedo` holds each relit pixel's
// implied albedo I / E_src per channel, `luminance_albedo` sum I / sum E_src (NaN where not
// relit). A pixel whose luminance albedo is more than the allowed factor above the median of its neighbours' of the
// same chromaticity (within albedo_check_radius_px; at least kMinNeighbours of them, itself counted) is brighter than
// its normal can explain: its ratio becomes a_ref E_dst / I, with a_ref those neighbours' per-channel median albedo, so
// that it is relit as a_ref E_dst(n). Returns how many pixels it replaced. Rows in parallel: each writes its own ratio
// row only.
int ReplaceInconsistentRatios(const cv::Mat& source, const cv::Mat& albedo, cv::Mat luminance_albedo,
                              const RelightOptions& options, cv::Mat* ratio) {
  constexpr int kMinNeighbours = 8;
  const cv::Size size = source.size();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Chromaticity (r, g) / (r + g + b) per relit pixel; black pixels are not checked.
  cv::Mat chroma(size, CV_32FC2, cv::Scalar(nan, nan));
  for (int y = 0; y < size.height; ++y) {
    const cv::Vec3f* in = source.ptr<cv::Vec3f>(y);
    cv::Vec2f* ch = chroma.ptr<cv::Vec2f>(y);
    float* la = luminance_albedo.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      const float sum = in[x][0] + in[x][1] + in[x][2];
      if (!std::isfinite(la[x])) continue;
      if (sum > 0.0f) {
        ch[x] = cv::Vec2f(in[x][0] / sum, in[x][1] / sum);
      } else {
        la[x] = nan;
      }
    }
  }
  const int radius = options.albedo_check_radius_px;
  const float tolerance = static_cast<float>(options.albedo_check_chromaticity_tolerance);
  const float deviation = static_cast<float>(options.max_albedo_deviation);
  std::vector<int> replaced_per_row(static_cast<std::size_t>(size.height), 0);
  ParallelForEach(0, size.height, [&](std::int64_t row) {
    const int y = static_cast<int>(row);
    std::vector<float> channel;
    const float* la = luminance_albedo.ptr<float>(y);
    const cv::Vec2f* ch = chroma.ptr<cv::Vec2f>(y);
    cv::Vec3f* r = ratio->ptr<cv::Vec3f>(y);
    const int y0 = std::max(0, y - radius), y1 = std::min(size.height - 1, y + radius);
    // The neighbours of (x, y) of the same chromaticity, in order.
    auto for_each_neighbour = [&](int x, auto&& visit) {
      for (int yy = y0; yy <= y1; ++yy) {
        const float* la_n = luminance_albedo.ptr<float>(yy);
        const cv::Vec2f* ch_n = chroma.ptr<cv::Vec2f>(yy);
        for (int xx = std::max(0, x - radius); xx <= std::min(size.width - 1, x + radius); ++xx) {
          if (std::isfinite(la_n[xx]) &&
              std::abs(ch_n[xx][0] - ch[x][0]) + std::abs(ch_n[xx][1] - ch[x][1]) <= tolerance) {
            visit(xx, yy, la_n[xx]);
          }
        }
      }
    };
    for (int x = 0; x < size.width; ++x) {
      if (!std::isfinite(la[x])) continue;
      // The median (element n / 2 in order) is below la / deviation when more than n / 2 of
      // the n neighbours are: counting decides without sorting.
      const float low = la[x] / deviation;
      int count = 0, below = 0;
      for_each_neighbour(x, [&](int, int, float a) {
        ++count;
        below += a < low;
      });
      if (count < kMinNeighbours || below < count / 2 + 1) continue;
      // Per-channel reference albedo from the same neighbours.
      const cv::Vec3f a = albedo.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        channel.clear();
        for_each_neighbour(x, [&](int xx, int yy, float) { channel.push_back(albedo.at<cv::Vec3f>(yy, xx)[c]); });
        const auto middle = channel.begin() + static_cast<std::ptrdiff_t>(channel.size() / 2);
        std::nth_element(channel.begin(), middle, channel.end());
        // I E_dst / E_src -> a_ref E_dst = I (E_dst / E_src) (a_ref / a).
        if (a[c] > 0.0f) r[x][c] *= *middle / a[c];
      }
      ++replaced_per_row[static_cast<std::size_t>(y)];
    }
  });
  int replaced = 0;
  for (int n : replaced_per_row) replaced += n;
  return replaced;
}

}  // namespace

bool RelightOptions::IsValid(std::string* why) const {
  if (!(min_irradiance_fraction > 0.0) || min_irradiance_fraction >= 1.0) {
    if (why) *why = "min_irradiance_fraction must be in (0, 1)";
    return false;
  }
  if (ratio_radius_px < 0 || ratio_radius_px > 32 || !(ratio_spatial_sigma_px > 0.0) || !(ratio_range_sigma > 0.0)) {
    if (why) *why = "ratio_radius_px must be in [0, 32] and the ratio filter's sigmas > 0";
    return false;
  }
  if (noisy_ratio_radius_px < 0 || noisy_ratio_radius_px > 32 || !(noisy_ratio_spatial_sigma_px > 0.0) ||
      !(noisy_ratio_range_sigma > 0.0)) {
    if (why) *why = "noisy_ratio_radius_px must be in [0, 32] and the noisy-normals ratio filter's sigmas > 0";
    return false;
  }
  if (!(max_albedo_deviation == 0.0 || max_albedo_deviation > 1.0) || albedo_check_radius_px < 1 ||
      albedo_check_radius_px > 16 || !(albedo_check_chromaticity_tolerance > 0.0)) {
    if (why) {
      *why =
          "max_albedo_deviation must be 0 (off) or > 1, albedo_check_radius_px in [1, 16] and "
          "albedo_check_chromaticity_tolerance > 0";
    }
    return false;
  }
  return true;
}

namespace {

// The checks RelightSh and RelightNonNegative share.
void CheckRelightInputs(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                        const RelightOptions& options) {
  ThrowIfInvalid(options, "relighting");
  if (src.pixels.type() != CV_32FC3) throw InvalidArgumentError("relighting: source must be an RGB radiance image");
  const cv::Size size = src.pixels.size();
  if (normal_in_camera.type() != CV_32FC3 || normal_in_camera.size() != size) {
    throw InvalidArgumentError("relighting: normals must be CV_32FC3 of the source image's size");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != size)) {
    throw InvalidArgumentError("relighting: mask must be CV_8UC1 of the source image's size");
  }
}

// The ratio relighting for any pair of irradiance functions of the unit normal (single
// precision): e_src(n), e_dst(n) -> Eigen::Vector3f.
template <class SourceIrradiance, class DestinationIrradiance>
RelightResult RelightByRatio(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                             const SourceIrradiance& e_src_of, const DestinationIrradiance& e_dst_of,
                             const RelightOptions& options) {
  const cv::Size size = src.pixels.size();
  RelightResult result;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  result.relit.unit = src.unit;
  result.relit.pixels = cv::Mat(size, CV_32FC3, cv::Scalar(nan, nan, nan));
  result.valid = cv::Mat::zeros(size, CV_8UC1);
  RelightSummary& summary = result.summary;
  // Per-channel floor: a fraction of the source irradiance averaged over the pixels to relight
  // (not over the whole sphere: a light fitted to the normals a camera sees is extrapolated
  // behind the object, and its sphere mean L00 can be negative while every visible normal is
  // well lit). A light whose mean over those pixels is not positive cannot be divided by.
  // `ratio` holds E_src per pixel after this pass (each pixel's irradiance is evaluated once),
  // and E_dst / E_src where relit after the next.
  cv::Mat ratio(size, CV_32FC3, cv::Scalar(nan, nan, nan));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0;
  for (int y = 0; y < size.height; ++y) {
    const unsigned char* m = mask.empty() ? nullptr : mask.ptr<unsigned char>(y);
    const cv::Vec3f* n = normal_in_camera.ptr<cv::Vec3f>(y);
    const cv::Vec3f* in = src.pixels.ptr<cv::Vec3f>(y);
    cv::Vec3f* r = ratio.ptr<cv::Vec3f>(y);
    for (int x = 0; x < size.width; ++x) {
      if ((m && !m[x]) || !std::isfinite(n[x][0] + n[x][1] + n[x][2] + in[x][0] + in[x][1] + in[x][2])) continue;
      const Eigen::Vector3f e = e_src_of(Eigen::Map<const Eigen::Vector3f>(&n[x][0]).normalized());
      r[x] = cv::Vec3f(e.x(), e.y(), e.z());
      sum += e.cast<double>();
      ++count;
    }
  }
  const Eigen::Vector3d mean = count > 0 ? Eigen::Vector3d(sum / count) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d floor = mean * options.min_irradiance_fraction;
  const bool light_ok = mean.minCoeff() > 0.0;
  const Eigen::Vector3f floor_f = floor.cast<float>();

  // The ratio E_dst / E_src per relit pixel (and, for the shading check, the implied albedo
  // I / E_src), then (filtered) times the source.
  const bool check_albedo = options.max_albedo_deviation > 0.0;
  cv::Mat albedo, luminance_albedo;
  if (check_albedo) {
    albedo = cv::Mat(size, CV_32FC3, cv::Scalar(nan, nan, nan));
    luminance_albedo = cv::Mat(size, CV_32FC1, cv::Scalar(nan));
  }
  for (int y = 0; y < size.height; ++y) {
    const unsigned char* m = mask.empty() ? nullptr : mask.ptr<unsigned char>(y);
    const cv::Vec3f* n = normal_in_camera.ptr<cv::Vec3f>(y);
    const cv::Vec3f* in = src.pixels.ptr<cv::Vec3f>(y);
    cv::Vec3f* out = ratio.ptr<cv::Vec3f>(y);
    unsigned char* valid = result.valid.ptr<unsigned char>(y);
    for (int x = 0; x < size.width; ++x) {
      if (m && !m[x]) continue;
      ++summary.requested_pixel_count;
      if (!std::isfinite(n[x][0] + n[x][1] + n[x][2] + in[x][0] + in[x][1] + in[x][2])) {
        ++summary.invalid_input_count;
        continue;
      }
      const Eigen::Vector3f e_src(out[x][0], out[x][1], out[x][2]);
      if (!light_ok || (e_src - floor_f).minCoeff() < 0.0f) {
        out[x] = cv::Vec3f(nan, nan, nan);
        ++summary.guarded_pixel_count;
        continue;
      }
      const Eigen::Vector3f e_dst = e_dst_of(Eigen::Map<const Eigen::Vector3f>(&n[x][0]).normalized());
      for (int c = 0; c < 3; ++c) out[x][c] = e_dst(c) / e_src(c);
      if (check_albedo) {
        cv::Vec3f& a = albedo.at<cv::Vec3f>(y, x);
        for (int c = 0; c < 3; ++c) a[c] = in[x][c] / e_src(c);
        luminance_albedo.at<float>(y, x) = (in[x][0] + in[x][1] + in[x][2]) / e_src.sum();
      }
      valid[x] = 255;
      ++summary.relit_pixel_count;
    }
  }
  if (check_albedo && light_ok) {
    summary.albedo_replaced_pixel_count =
        ReplaceInconsistentRatios(src.pixels, albedo, std::move(luminance_albedo), options, &ratio);
  }
  const RatioFilter filter = RatioFilterOf(options);
  if (filter.radius_px > 0) ratio = FilterRatio(ratio, result.valid, src.pixels, filter);
  for (int y = 0; y < size.height; ++y) {
    const unsigned char* valid = result.valid.ptr<unsigned char>(y);
    const cv::Vec3f* r = ratio.ptr<cv::Vec3f>(y);
    const cv::Vec3f* in = src.pixels.ptr<cv::Vec3f>(y);
    cv::Vec3f* out = result.relit.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < size.width; ++x) {
      if (valid[x]) out[x] = cv::Vec3f(in[x][0] * r[x][0], in[x][1] * r[x][1], in[x][2] * r[x][2]);
    }
  }
  if (!light_ok)
    summary.message =
        "source light has no positive mean irradiance over the pixels to relight in some channel: nothing relit";
  else if (summary.guarded_pixel_count > 0) {
    summary.message = std::to_string(summary.guarded_pixel_count) +
                      " pixel(s) not relit: source irradiance below the guard (min_irradiance_fraction)";
  }
  return result;
}

}  // namespace

RelightResult RelightSh(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                        const ShRgb& src_light, const ShRgb& dst_light, const RelightOptions& options) {
  CheckRelightInputs(src, normal_in_camera, mask, options);
  if (!src_light.allFinite() || !dst_light.allFinite()) {
    throw InvalidArgumentError("relighting: SH coefficients must be finite");
  }
  // Single-precision kernels for speed: 9 x 3 coefficients, pre-multiplied by A_l.
  Eigen::Matrix<float, 3, kShCount> src_k, dst_k;
  for (int k = 0; k < kShCount; ++k) {
    const int l = k == 0 ? 0 : k < 4 ? 1 : 2;
    src_k.col(k) = (src_light.row(k) * ShBandFactor(l)).transpose().cast<float>();
    dst_k.col(k) = (dst_light.row(k) * ShBandFactor(l)).transpose().cast<float>();
  }
  return RelightByRatio(
      src, normal_in_camera, mask, [&](const Eigen::Vector3f& n) -> Eigen::Vector3f { return src_k * BasisF(n); },
      [&](const Eigen::Vector3f& n) -> Eigen::Vector3f { return dst_k * BasisF(n); }, options);
}

namespace {

// A NonNegativeLight in single precision for the per-pixel loop.
struct DirectionalSources {
  explicit DirectionalSources(const NonNegativeLight& light) {
    if (light.directions.size() != light.irradiance.size()) {
      throw InvalidArgumentError("relighting: a non-negative light needs one irradiance per direction");
    }
    for (std::size_t j = 0; j < light.directions.size(); ++j) {
      if (!light.directions[j].allFinite() || !light.irradiance[j].allFinite() ||
          light.irradiance[j].minCoeff() < 0.0) {
        throw InvalidArgumentError(
            "relighting: a non-negative light's directions and irradiances must be finite, "
            "and its irradiances >= 0");
      }
      directions.push_back(light.directions[j].normalized().cast<float>());
      irradiance.push_back(light.irradiance[j].cast<float>());
    }
  }
  Eigen::Vector3f operator()(const Eigen::Vector3f& n) const {
    Eigen::Vector3f e = Eigen::Vector3f::Zero();
    for (std::size_t j = 0; j < directions.size(); ++j) e += irradiance[j] * std::max(0.0f, n.dot(directions[j]));
    return e;
  }
  std::vector<Eigen::Vector3f> directions, irradiance;
};

}  // namespace

RelightResult RelightNonNegative(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                                 const NonNegativeLight& src_light, const NonNegativeLight& dst_light,
                                 const RelightOptions& options) {
  CheckRelightInputs(src, normal_in_camera, mask, options);
  const DirectionalSources e_src(src_light), e_dst(dst_light);
  return RelightByRatio(src, normal_in_camera, mask, e_src, e_dst, options);
}

RadianceImage Composite(const RadianceImage& foreground, const cv::Mat& mask, const RadianceImage& background) {
  if (foreground.pixels.type() != CV_32FC3 || background.pixels.type() != CV_32FC3 ||
      foreground.pixels.size() != background.pixels.size()) {
    throw InvalidArgumentError("composite: foreground and background must be RGB radiance images of one size");
  }
  if (mask.type() != CV_8UC1 || mask.size() != foreground.pixels.size()) {
    throw InvalidArgumentError("composite: mask must be CV_8UC1 of the images' size");
  }
  RadianceImage out;
  out.unit = background.unit;
  out.pixels = background.pixels.clone();
  for (int y = 0; y < mask.rows; ++y) {
    const unsigned char* m = mask.ptr<unsigned char>(y);
    const cv::Vec3f* f = foreground.pixels.ptr<cv::Vec3f>(y);
    cv::Vec3f* o = out.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (m[x] && std::isfinite(f[x][0] + f[x][1] + f[x][2])) o[x] = f[x];
    }
  }
  return out;
}

}  // namespace relume::processing
