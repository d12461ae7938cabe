#include "processing/segmentation.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/core.hpp>

#include "core/error.h"

namespace relume::processing {
namespace {

bool Fail(std::string* why, const char* reason) {
  if (why) *why = reason;
  return false;
}

}  // namespace

bool SegmentationOptions::IsValid(std::string* why) const {
  if (segment_count < 1 || segment_count > 64) return Fail(why, "segment_count must be in [1, 64]");
  if (!(normal_weight >= 0.0) || !std::isfinite(normal_weight)) return Fail(why, "normal_weight must be >= 0");
  if (max_cluster_pixels < segment_count) return Fail(why, "max_cluster_pixels must be >= segment_count");
  if (attempts < 1 || max_iterations < 1) return Fail(why, "attempts and max_iterations must be >= 1");
  return true;
}

bool SamplePointOptions::IsValid(std::string* why) const {
  if (count < 1) return Fail(why, "count must be >= 1");
  return true;
}

Segmentation SegmentByColor(const RadianceImage& radiance, const cv::Mat& mask, const cv::Mat& normal_in_camera,
                            const SegmentationOptions& options) {
  ThrowIfInvalid(options, "segmentation");
  if (radiance.pixels.type() != CV_32FC3) throw InvalidArgumentError("segmentation: radiance must be RGB float");
  if (mask.type() != CV_8UC1 || mask.size() != radiance.pixels.size()) {
    throw InvalidArgumentError("segmentation: mask must be CV_8UC1 of the radiance image's size");
  }
  const bool use_normals = options.use_normals;
  if (use_normals && (normal_in_camera.type() != CV_32FC3 || normal_in_camera.size() != mask.size())) {
    throw InvalidArgumentError("segmentation: use_normals needs a CV_32FC3 normal map of the image's size");
  }
  const int dims = use_normals ? 5 : 2;
  const float nw = static_cast<float>(options.normal_weight);

  // Usable pixels and their features.
  std::vector<cv::Point> pixels;
  std::vector<float> features;
  for (int y = 0; y < mask.rows; ++y) {
    const unsigned char* m = mask.ptr<unsigned char>(y);
    const cv::Vec3f* c = radiance.pixels.ptr<cv::Vec3f>(y);
    const cv::Vec3f* n = use_normals ? normal_in_camera.ptr<cv::Vec3f>(y) : nullptr;
    for (int x = 0; x < mask.cols; ++x) {
      if (!m[x]) continue;
      const float sum = c[x][0] + c[x][1] + c[x][2];
      if (!std::isfinite(sum) || !(sum > 1e-12f) || c[x][0] < 0 || c[x][1] < 0 || c[x][2] < 0) continue;
      if (use_normals && !std::isfinite(n[x][2])) continue;
      pixels.emplace_back(x, y);
      features.push_back(c[x][0] / sum);
      features.push_back(c[x][1] / sum);
      if (use_normals) {
        for (int k = 0; k < 3; ++k) features.push_back(nw * n[x][k]);
      }
    }
  }

  Segmentation result;
  result.labels = cv::Mat(mask.size(), CV_32SC1, cv::Scalar(-1));
  const int usable = static_cast<int>(pixels.size());
  const int k = std::min(options.segment_count, usable);
  if (k == 0) return result;

  // k-means on an evenly strided subset, then nearest-centre assignment for every pixel.
  const int step = std::max(1, usable / options.max_cluster_pixels);
  cv::Mat subset(0, dims, CV_32F);
  for (int i = 0; i < usable; i += step) subset.push_back(cv::Mat(1, dims, CV_32F, &features[i * dims]));
  cv::Mat sub_labels, centres;
  cv::theRNG().state = options.seed;  // cv::kmeans draws from OpenCV's thread RNG
  cv::kmeans(subset, std::min(k, subset.rows), sub_labels,
             cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options.max_iterations, 1e-6),
             options.attempts, cv::KMEANS_PP_CENTERS, centres);
  const int clusters = centres.rows;
  std::vector<int> assignment(usable);
  std::vector<int> counts(clusters, 0);
  for (int i = 0; i < usable; ++i) {
    const float* f = &features[i * dims];
    int best = 0;
    float best_d = std::numeric_limits<float>::infinity();
    for (int c = 0; c < clusters; ++c) {
      const float* centre = centres.ptr<float>(c);
      float d = 0.0f;
      for (int j = 0; j < dims; ++j) d += (f[j] - centre[j]) * (f[j] - centre[j]);
      if (d < best_d) best_d = d, best = c;
    }
    assignment[i] = best;
    ++counts[best];
  }
  // Renumber by size, dropping empty clusters.
  std::vector<int> order(clusters);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return counts[a] > counts[b]; });
  std::vector<int> new_label(clusters, -1);
  for (int i = 0; i < clusters && counts[order[i]] > 0; ++i) {
    new_label[order[i]] = i;
    result.pixel_count.push_back(counts[order[i]]);
  }
  result.mean_color.assign(result.pixel_count.size(), cv::Vec3f(0, 0, 0));
  for (int i = 0; i < usable; ++i) {
    const int label = new_label[assignment[i]];
    result.labels.at<int>(pixels[i]) = label;
    result.mean_color[label] += radiance.pixels.at<cv::Vec3f>(pixels[i]);
  }
  for (size_t l = 0; l < result.mean_color.size(); ++l)
    result.mean_color[l] /= static_cast<float>(result.pixel_count[l]);
  return result;
}

cv::Mat SegmentMask(const Segmentation& segmentation, int label) {
  cv::Mat out = segmentation.labels == label;
  return out;
}

SamplePointSelector::SamplePointSelector(const SamplePointOptions& options) : options_(options), rng_(options.seed) {
  ThrowIfInvalid(options_, "sample points");
}

const std::vector<cv::Point>& SamplePointSelector::Update(const cv::Mat& allowed) {
  if (allowed.type() != CV_8UC1) throw InvalidArgumentError("sample points: the allowed region must be CV_8UC1");
  // Keep the points still inside (and inside the image).
  cv::Mat taken = cv::Mat::zeros(allowed.size(), CV_8UC1);
  std::vector<cv::Point> kept;
  kept.reserve(points_.size());
  for (const cv::Point& p : points_) {
    if (p.x < allowed.cols && p.y < allowed.rows && allowed.at<unsigned char>(p) && !taken.at<unsigned char>(p)) {
      kept.push_back(p);
      taken.at<unsigned char>(p) = 1;
    }
  }
  kept_ = static_cast<int>(kept.size());
  // Refill from the free pixels of the region: a partial Fisher-Yates draw without repeats.
  std::vector<cv::Point> free;
  for (int y = 0; y < allowed.rows; ++y) {
    const unsigned char* a = allowed.ptr<unsigned char>(y);
    const unsigned char* t = taken.ptr<unsigned char>(y);
    for (int x = 0; x < allowed.cols; ++x) {
      if (a[x] && !t[x]) free.emplace_back(x, y);
    }
  }
  const size_t needed = std::min(free.size(), static_cast<size_t>(options_.count) - kept.size());
  for (size_t i = 0; i < needed; ++i) {
    std::uniform_int_distribution<size_t> pick(i, free.size() - 1);
    std::swap(free[i], free[pick(rng_)]);
    kept.push_back(free[i]);
  }
  reselected_ = static_cast<int>(needed);
  points_ = std::move(kept);
  return points_;
}

}  // namespace relume::processing
