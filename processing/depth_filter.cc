#include "processing/depth_filter.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "core/error.h"

namespace relume::processing {
namespace {

bool Fail(std::string* why, const char* reason) {
  if (why) *why = reason;
  return false;
}

void CheckDepth(const cv::Mat& depth_m, const char* what) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1) {
    throw InvalidArgumentError(std::string(what) + ": depth must be a non-empty CV_32FC1 image in metres");
  }
}

// exp(-x) for x = (d / sigma)^2 / 2 in [0, x_max], sampled finely enough (4096 steps) that
// the weights differ from exp() by < 1e-3 of their value.
class NegExpTable {
 public:
  explicit NegExpTable(double x_max) : scale_(kSize / x_max) {
    for (int i = 0; i <= kSize; ++i) table_[i] = static_cast<float>(std::exp(-(i + 0.5) / scale_));
  }
  float operator()(float x) const { return table_[static_cast<int>(x * scale_)]; }

 private:
  static constexpr int kSize = 4096;
  float scale_;
  std::array<float, kSize + 1> table_;
};

}  // namespace

bool BilateralDepthOptions::IsValid(std::string* why) const {
  if (radius_px < 0 || radius_px > 15) return Fail(why, "radius_px must be in [0, 15]");
  if (!(spatial_sigma_px > 0.0) || !std::isfinite(spatial_sigma_px)) return Fail(why, "spatial_sigma_px must be > 0");
  if (!(range_sigma_at_1m_m > 0.0) || !std::isfinite(range_sigma_at_1m_m)) {
    return Fail(why, "range_sigma_at_1m_m must be > 0");
  }
  if (!(edge_cut_sigmas > 0.0) || edge_cut_sigmas > 10.0) return Fail(why, "edge_cut_sigmas must be in (0, 10]");
  return true;
}

bool TemporalDepthOptions::IsValid(std::string* why) const {
  if (!(weight >= 0.0) || !std::isfinite(weight)) return Fail(why, "weight must be >= 0");
  if (!(max_difference_sigmas > 0.0) || !std::isfinite(max_difference_sigmas)) {
    return Fail(why, "max_difference_sigmas must be > 0");
  }
  if (!(range_sigma_at_1m_m > 0.0) || !std::isfinite(range_sigma_at_1m_m)) {
    return Fail(why, "range_sigma_at_1m_m must be > 0");
  }
  return true;
}

DepthNoiseEstimate EstimateDepthNoise(const cv::Mat& depth_m, double edge_jump_fraction) {
  CheckDepth(depth_m, "EstimateDepthNoise");
  if (!(edge_jump_fraction > 0.0)) throw InvalidArgumentError("EstimateDepthNoise: edge_jump_fraction must be > 0");
  static constexpr std::array<double, 5> kWeights = {1.0, -4.0, 6.0, -4.0, 1.0};
  const double norm = std::sqrt(70.0);  // sqrt of the sum of the squared weights
  std::vector<double> values;
  values.reserve(depth_m.total() / 2);
  auto window = [&](auto at) {  // at(k), k = -2..2, along one axis
    const float centre = at(0);
    if (!IsDepthValid(centre)) return;
    double d4 = 0.0;
    for (int k = -2; k <= 2; ++k) {
      const float z = at(k);
      if (!IsDepthValid(z) || std::abs(z - centre) > edge_jump_fraction * centre) return;
      d4 += kWeights[static_cast<std::size_t>(k + 2)] * z;
    }
    values.push_back(std::abs(d4) / (norm * static_cast<double>(centre) * centre));
  };
  // Stairs: rows of five valid samples within 10 % of the centre's depth (one surface, maybe
  // across quantisation steps, not across a silhouette) that are not flat (first != last) yet
  // hold two exactly equal neighbours. Smooth float depth has none; a fronto-parallel plane is
  // flat and does not count. Counted in the same pass over the rows as their differences.
  DepthNoiseEstimate estimate;
  int sloped = 0, stairs = 0;
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* row = depth_m.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      if (!IsDepthValid(row[x])) continue;
      ++estimate.valid_pixels;
      if (x < 2 || x + 2 >= depth_m.cols) continue;
      window([&](int k) { return row[x + k]; });
      bool usable = true, equal = false;
      for (int k = -2; k <= 2 && usable; ++k) {
        usable = IsDepthValid(row[x + k]) && std::abs(row[x + k] - row[x]) <= 0.1f * row[x];
        if (usable && k < 2) equal = equal || row[x + k] == row[x + k + 1];
      }
      if (!usable || row[x - 2] == row[x + 2]) continue;
      ++sloped;
      stairs += equal;
    }
  }
  for (int y = 2; y + 2 < depth_m.rows; ++y) {
    for (int x = 0; x < depth_m.cols; ++x) window([&](int k) { return depth_m.at<float>(y + k, x); });
  }
  estimate.samples = static_cast<int>(values.size());
  estimate.stair_fraction = sloped > 0 ? static_cast<double>(stairs) / sloped : 0.0;
  if (values.empty()) {
    estimate.sigma_at_1m_m = std::numeric_limits<double>::quiet_NaN();
    return estimate;
  }
  // RMS of the lower 98 %: the top 2 % are creases, rims and other non-cubic windows. A median
  // would not do: rounding a gently sloped surface gives mostly exact zeros.
  const auto cut = values.begin() + static_cast<std::ptrdiff_t>(values.size() * 98 / 100);
  std::nth_element(values.begin(), cut, values.end());
  double sum_squares = 0.0;
  for (auto it = values.begin(); it != cut; ++it) sum_squares += *it * *it;
  const auto kept = static_cast<double>(std::max<std::ptrdiff_t>(1, cut - values.begin()));
  // Gaussian noise trimmed at its 98th |x| percentile keeps 0.9346 of its RMS.
  estimate.sigma_at_1m_m = std::sqrt(sum_squares / kept) / 0.9346;
  return estimate;
}

bool DepthNoiseEstimate::NoiseFree(double sigma_limit_at_1m_m) const {
  return samples > 0 && sigma_at_1m_m < sigma_limit_at_1m_m && stair_fraction < 0.1 &&
         samples >= valid_pixels;  // two windows per pixel: at least half of them usable
}

std::string DepthNoiseEstimate::Describe() const {
  char text[160];
  std::snprintf(text, sizeof(text),
                "%.3g mm at 1 m (%d fourth differences over %d pixels, stairs in %.1f %% of sloped rows)",
                sigma_at_1m_m * 1e3, samples, valid_pixels, 100.0 * stair_fraction);
  return text;
}

cv::Mat BilateralFilterDepth(const cv::Mat& depth_m, const BilateralDepthOptions& options) {
  ThrowIfInvalid(options, "bilateral depth filter");
  CheckDepth(depth_m, "bilateral depth filter");
  const int rows = depth_m.rows, cols = depth_m.cols, r = options.radius_px;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat out(rows, cols, CV_32FC1, cv::Scalar(nan));

  const int side = 2 * r + 1;
  std::vector<float> spatial(side * side);
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      spatial[(dy + r) * side + dx + r] = static_cast<float>(
          std::exp(-(dx * dx + dy * dy) / (2.0 * options.spatial_sigma_px * options.spatial_sigma_px)));
    }
  }
  const float cut = static_cast<float>(options.edge_cut_sigmas);
  const float cut_x = 0.5f * cut * cut;  // the largest range exponent still weighted
  const NegExpTable neg_exp(cut_x);
  const float sigma_1m = static_cast<float>(options.range_sigma_at_1m_m);

  for (int y = 0; y < rows; ++y) {
    const float* centre_row = depth_m.ptr<float>(y);
    float* out_row = out.ptr<float>(y);
    const int y0 = std::max(0, y - r), y1 = std::min(rows - 1, y + r);
    for (int x = 0; x < cols; ++x) {
      const float z = centre_row[x];
      if (!IsDepthValid(z)) continue;  // holes stay holes
      const float sigma = sigma_1m * z * z;
      const float inv_two_sigma_sq = 0.5f / (sigma * sigma);
      const int x0 = std::max(0, x - r), x1 = std::min(cols - 1, x + r);
      float weight_sum = 0.0f, value_sum = 0.0f;
      for (int yy = y0; yy <= y1; ++yy) {
        const float* row = depth_m.ptr<float>(yy);
        const float* spatial_row = &spatial[(yy - y + r) * side + r - x];
        for (int xx = x0; xx <= x1; ++xx) {
          const float d = row[xx];
          if (!IsDepthValid(d)) continue;
          const float diff = d - z;
          const float exponent = diff * diff * inv_two_sigma_sq;
          if (exponent >= cut_x) continue;  // across a discontinuity: no weight at all
          const float w = spatial_row[xx] * neg_exp(exponent);
          weight_sum += w;
          value_sum += w * d;
        }
      }
      out_row[x] = value_sum / weight_sum;  // weight_sum >= the centre's own weight > 0
    }
  }
  return out;
}

cv::Mat TemporalFilterDepth(const cv::Mat& current_m, const cv::Mat& previous_m, const TemporalDepthOptions& options,
                            int* blended_pixel_count) {
  ThrowIfInvalid(options, "temporal depth filter");
  CheckDepth(current_m, "temporal depth filter");
  cv::Mat out = current_m.clone();
  int blended = 0;
  if (!previous_m.empty() && options.weight > 0.0) {
    CheckDepth(previous_m, "temporal depth filter (previous frame)");
    if (previous_m.size() != current_m.size()) {
      throw InvalidArgumentError("temporal depth filter: previous and current frames differ in size");
    }
    const float w = static_cast<float>(options.weight);
    const float a = (w + 1.0f) / (2.0f * w + 1.0f), b = w / (2.0f * w + 1.0f);
    const float k = static_cast<float>(options.max_difference_sigmas * options.range_sigma_at_1m_m);
    for (int y = 0; y < out.rows; ++y) {
      const float* prev = previous_m.ptr<float>(y);
      float* cur = out.ptr<float>(y);
      for (int x = 0; x < out.cols; ++x) {
        const float z = cur[x], zp = prev[x];
        if (!IsDepthValid(z) || !IsDepthValid(zp)) continue;
        if (std::abs(z - zp) > k * z * z) continue;  // moved: keep the current value
        cur[x] = a * z + b * zp;
        ++blended;
      }
    }
  }
  if (blended_pixel_count) *blended_pixel_count = blended;
  return out;
}

DepthDenoiser::DepthDenoiser(const BilateralDepthOptions& bilateral, const TemporalDepthOptions& temporal)
    : bilateral_(bilateral), temporal_(temporal) {
  ThrowIfInvalid(bilateral_, "bilateral depth filter");
  ThrowIfInvalid(temporal_, "temporal depth filter");
}

cv::Mat DepthDenoiser::Process(const cv::Mat& depth_m) {
  cv::Mat filtered = BilateralFilterDepth(depth_m, bilateral_);
  if (!previous_.empty() && previous_.size() != filtered.size()) previous_.release();
  cv::Mat out = TemporalFilterDepth(filtered, previous_, temporal_, &last_blended_);
  previous_ = filtered;
  return out;
}

}  // namespace relume::processing
