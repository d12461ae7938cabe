#include "processing/segmentation.h"

#include <algorithm>
#include <cmath>
#include <limits>
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

namespace {

// The usable pixels of a frame, their features (see the header), `dims` floats per pixel, and
// their mean colour.
struct Features {
  std::vector<cv::Point> pixels;
  std::vector<float> values;
  int dims = 2;
  cv::Vec3d mean_color{0, 0, 0};
};

Features FrameFeatures(const RadianceImage& radiance, const cv::Mat& mask, const cv::Mat& normal_in_camera,
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
  Features f;
  f.dims = use_normals ? 5 : 2;
  const float nw = static_cast<float>(options.normal_weight);
  for (int y = 0; y < mask.rows; ++y) {
    const unsigned char* m = mask.ptr<unsigned char>(y);
    const cv::Vec3f* c = radiance.pixels.ptr<cv::Vec3f>(y);
    const cv::Vec3f* n = use_normals ? normal_in_camera.ptr<cv::Vec3f>(y) : nullptr;
    for (int x = 0; x < mask.cols; ++x) {
      if (!m[x]) continue;
      const float sum = c[x][0] + c[x][1] + c[x][2];
      if (!std::isfinite(sum) || !(sum > 1e-12f) || c[x][0] < 0 || c[x][1] < 0 || c[x][2] < 0) continue;
      if (use_normals && !std::isfinite(n[x][2])) continue;
      f.pixels.emplace_back(x, y);
      f.values.push_back(c[x][0] / sum);
      f.values.push_back(c[x][1] / sum);
      if (use_normals) {
        for (int k = 0; k < 3; ++k) f.values.push_back(nw * n[x][k]);
      }
      f.mean_color += cv::Vec3d(c[x][0], c[x][1], c[x][2]);
    }
  }
  if (!f.pixels.empty()) f.mean_color /= static_cast<double>(f.pixels.size());
  return f;
}

// The chromaticity features again, of the colours times `gain` per channel.
void Rebalance(const RadianceImage& radiance, const cv::Vec3d& gain, Features* f) {
  for (std::size_t i = 0; i < f->pixels.size(); ++i) {
    const cv::Vec3f c = radiance.pixels.at<cv::Vec3f>(f->pixels[i]);
    const cv::Vec3d g(gain[0] * c[0], gain[1] * c[1], gain[2] * c[2]);
    const double sum = g[0] + g[1] + g[2];
    float* v = &f->values[i * static_cast<std::size_t>(f->dims)];
    v[0] = static_cast<float>(g[0] / sum);
    v[1] = static_cast<float>(g[1] / sum);
  }
}

// The squared distance of pixel i's features to a centre (f.dims floats).
float FeatureDistance2(const Features& f, std::size_t i, const float* c) {
  const float* p = &f.values[i * static_cast<std::size_t>(f.dims)];
  float d = 0.0f;
  for (int j = 0; j < f.dims; ++j) d += (p[j] - c[j]) * (p[j] - c[j]);
  return d;
}

// The nearest centre (a row of `centres`) to each pixel's features, and the squared distance.
void NearestCentres(const Features& f, const cv::Mat& centres, std::vector<int>* nearest,
                    std::vector<float>* distance2) {
  const std::size_t usable = f.pixels.size();
  nearest->assign(usable, 0);
  distance2->assign(usable, std::numeric_limits<float>::infinity());
  for (std::size_t i = 0; i < usable; ++i) {
    for (int c = 0; c < centres.rows; ++c) {
      const float d = FeatureDistance2(f, i, centres.ptr<float>(c));
      if (d < (*distance2)[i]) (*distance2)[i] = d, (*nearest)[i] = c;
    }
  }
}

// Fills labels (already -1 everywhere), mean_color and spread from the pixels' labels.
void LabelStatistics(const Features& f, const std::vector<int>& label, const std::vector<float>& distance2,
                     const RadianceImage& radiance, Segmentation* s) {
  const std::size_t segments = s->pixel_count.size();
  s->mean_color.assign(segments, cv::Vec3f(0, 0, 0));
  std::vector<double> sum_d2(segments, 0.0);
  for (std::size_t i = 0; i < f.pixels.size(); ++i) {
    if (label[i] < 0) continue;
    const auto l = static_cast<std::size_t>(label[i]);
    s->labels.at<int>(f.pixels[i]) = label[i];
    s->mean_color[l] += radiance.pixels.at<cv::Vec3f>(f.pixels[i]);
    sum_d2[l] += distance2[i];
  }
  s->frame_mean_color = cv::Vec3f(f.mean_color);
  s->spread.assign(segments, 0.0f);
  for (std::size_t l = 0; l < segments; ++l) {
    if (s->pixel_count[l] == 0) continue;
    s->mean_color[l] /= static_cast<float>(s->pixel_count[l]);
    s->spread[l] = static_cast<float>(std::sqrt(sum_d2[l] / s->pixel_count[l]));
  }
}

}  // namespace

Segmentation SegmentByColor(const RadianceImage& radiance, const cv::Mat& mask, const cv::Mat& normal_in_camera,
                            const SegmentationOptions& options) {
  Features f = FrameFeatures(radiance, mask, normal_in_camera, options);
  const int dims = f.dims;
  Segmentation result;
  result.labels = cv::Mat(mask.size(), CV_32SC1, cv::Scalar(-1));
  result.centres = cv::Mat(0, dims, CV_32F);
  const int usable = static_cast<int>(f.pixels.size());
  const int k = std::min(options.segment_count, usable);
  if (k == 0) return result;
  // k-means on an evenly strided subset, then nearest-centre assignment for every pixel.
  const int step = std::max(1, usable / options.max_cluster_pixels);
  cv::Mat subset(0, dims, CV_32F);
  for (int i = 0; i < usable; i += step) {
    subset.push_back(cv::Mat(1, dims, CV_32F, &f.values[static_cast<std::size_t>(i * dims)]));
  }
  cv::Mat sub_labels, centres;
  cv::theRNG().state = options.seed;  // cv::kmeans draws from OpenCV's thread RNG
  cv::kmeans(subset, std::min(k, subset.rows), sub_labels,
             cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options.max_iterations, 1e-6),
             options.attempts, cv::KMEANS_PP_CENTERS, centres);
  const int clusters = centres.rows;
  std::vector<int> assignment;
  std::vector<float> distance2;
  NearestCentres(f, centres, &assignment, &distance2);
  std::vector<int> counts(clusters, 0);
  for (const int a : assignment) ++counts[a];
  // Renumber by size, dropping empty clusters.
  std::vector<int> order(clusters);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return counts[a] > counts[b]; });
  std::vector<int> new_label(clusters, -1);
  for (int i = 0; i < clusters && counts[order[i]] > 0; ++i) {
    new_label[order[i]] = i;
    result.pixel_count.push_back(counts[order[i]]);
    result.centres.push_back(centres.row(order[i]));
  }
  for (int& a : assignment) a = new_label[a];
  LabelStatistics(f, assignment, distance2, radiance, &result);
  return result;
}

bool LabelByCentresOptions::IsValid(std::string* why) const {
  if (!(max_spread_factor >= 0.0) || !std::isfinite(max_spread_factor))
    return Fail(why, "max_spread_factor must be >= 0");
  if (!(min_distance >= 0.0) || !std::isfinite(min_distance)) return Fail(why, "min_distance must be >= 0");
  return true;
}

Segmentation LabelByCentres(const Segmentation& reference, const RadianceImage& radiance, const cv::Mat& mask,
                            const cv::Mat& normal_in_camera, const SegmentationOptions& options,
                            const LabelByCentresOptions& label_options, const cv::Mat& same_surface) {
  ThrowIfInvalid(label_options, "labelling by centres");
  if (!same_surface.empty() && (same_surface.type() != CV_8UC1 || same_surface.size() != mask.size() ||
                                reference.labels.size() != mask.size())) {
    throw InvalidArgumentError(
        "labelling by centres: same_surface must be CV_8UC1 of the frame's size, as the reference's labels");
  }
  Features f = FrameFeatures(radiance, mask, normal_in_camera, options);
  // This frame's colour balance mapped onto the reference's (von Kries, by the mean colours), so
  // that a change in the light's colour does not move the chromaticities.
  if (label_options.balance_colour) {
    cv::Vec3d gain(1, 1, 1);
    for (int c = 0; c < 3; ++c) {
      if (f.mean_color[c] > 0.0 && reference.frame_mean_color[c] > 0.0f) {
        gain[c] = static_cast<double>(reference.frame_mean_color[c]) / f.mean_color[c];
      }
    }
    Rebalance(radiance, gain, &f);
  }
  const int segments = reference.segment_count();
  if (reference.centres.type() != CV_32F || reference.centres.rows != segments || reference.centres.cols != f.dims ||
      reference.spread.size() != static_cast<std::size_t>(segments)) {
    throw InvalidArgumentError("labelling by centres: the reference segmentation has no centres for these options (" +
                               std::to_string(reference.centres.rows) + " x " + std::to_string(reference.centres.cols) +
                               " for " + std::to_string(segments) + " segment(s) of " + std::to_string(f.dims) +
                               " features)");
  }
  Segmentation result;
  result.labels = cv::Mat(mask.size(), CV_32SC1, cv::Scalar(-1));
  result.centres = reference.centres.clone();
  result.pixel_count.assign(static_cast<std::size_t>(segments), 0);
  if (segments == 0) {
    result.spread.clear();
    return result;
  }
  std::vector<int> nearest;
  std::vector<float> distance2;
  NearestCentres(f, reference.centres, &nearest, &distance2);
  for (std::size_t i = 0; i < nearest.size(); ++i) {
    const cv::Point p = f.pixels[i];
    if (!same_surface.empty() && same_surface.at<std::uint8_t>(p) != 0) {
      nearest[i] = reference.labels.at<int>(p);
      if (nearest[i] >= 0) {
        distance2[i] = FeatureDistance2(f, i, reference.centres.ptr<float>(nearest[i]));
        ++result.pixel_count[static_cast<std::size_t>(nearest[i])];
      }
      continue;
    }
    const auto l = static_cast<std::size_t>(nearest[i]);
    const double bound = std::max(label_options.max_spread_factor * reference.spread[l], label_options.min_distance);
    if (static_cast<double>(distance2[i]) > bound * bound) {
      nearest[i] = -1;
      continue;
    }
    ++result.pixel_count[l];
  }
  LabelStatistics(f, nearest, distance2, radiance, &result);
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
