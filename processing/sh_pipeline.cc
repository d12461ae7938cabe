#include "processing/sh_pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>

#include "core/error.h"

namespace relume::processing {
namespace {

// Bounding rectangle of the non-zero pixels (empty when there are none).
cv::Rect MaskBounds(const cv::Mat& mask) {
  int x0 = mask.cols, y0 = mask.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < mask.rows; ++y) {
    const unsigned char* m = mask.ptr<unsigned char>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (!m[x]) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  }
  return x1 < 0 ? cv::Rect() : cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

// Normals on the crop, with the principal point moved to it, pasted into full-size maps.
NormalMap NormalsOnRoi(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics, const cv::Rect& roi,
                       const NormalOptions& options) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const cv::Rect full(0, 0, depth_m.cols, depth_m.rows);
  if (roi == full) return EstimateNormals(depth_m, intrinsics, options);
  NormalMap normals;
  normals.normal_in_camera = cv::Mat(depth_m.size(), CV_32FC3, cv::Scalar(nan, nan, nan));
  normals.valid = cv::Mat::zeros(depth_m.size(), CV_8UC1);
  normals.method = cv::Mat::zeros(depth_m.size(), CV_8UC1);
  if (roi.empty()) return normals;
  PinholeIntrinsics crop = intrinsics;
  crop.width = roi.width;
  crop.height = roi.height;
  crop.cx -= roi.x;
  crop.cy -= roi.y;
  const NormalMap part = EstimateNormals(depth_m(roi), crop, options);
  part.normal_in_camera.copyTo(normals.normal_in_camera(roi));
  part.valid.copyTo(normals.valid(roi));
  part.method.copyTo(normals.method(roi));
  normals.integral_count = part.integral_count;
  normals.cross_count = part.cross_count;
  normals.crease_count = part.crease_count;
  normals.neighbour_box_count = part.neighbour_box_count;
  normals.jet_count = part.jet_count;
  normals.invalid_count = part.invalid_count;
  return normals;
}

}  // namespace

bool ShGeometryOptions::IsValid(std::string* why) const {
  if (!bilateral.IsValid(why) || !temporal.IsValid(why) || !normals.IsValid(why)) return false;
  if (!(reuse_sigmas > 0.0) || !(reuse_max_changed_fraction >= 0.0 && reuse_max_changed_fraction <= 1.0)) {
    if (why) *why = "reuse_sigmas must be > 0 and reuse_max_changed_fraction within [0, 1]";
    return false;
  }
  if (!(skip_filter_below_at_1m_m >= 0.0)) {
    if (why) *why = "skip_filter_below_at_1m_m must be >= 0 (metres at 1 m; 0: always filter)";
    return false;
  }
  return true;
}

cv::Mat MaskWithDepth(const cv::Mat& valid, const cv::Mat& depth_m) {
  cv::Mat mask = valid.clone();
  for (int y = 0; y < mask.rows; ++y) {
    const float* z = depth_m.ptr<float>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (!IsDepthValid(z[x])) mask.at<std::uint8_t>(y, x) = 0;
    }
  }
  return mask;
}

cv::Mat UnchangedDepthMask(const cv::Mat& a, const cv::Mat& b, double sigma_at_1m, double sigmas) {
  RELUME_CHECK(a.type() == CV_32FC1 && b.type() == CV_32FC1 && a.size() == b.size());
  cv::Mat same = cv::Mat::zeros(a.size(), CV_8UC1);
  for (int y = 0; y < a.rows; ++y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    std::uint8_t* out = same.ptr<std::uint8_t>(y);
    for (int x = 0; x < a.cols; ++x) {
      if (!IsDepthValid(pa[x]) || !IsDepthValid(pb[x])) continue;
      const double z = pa[x];
      if (std::abs(pa[x] - pb[x]) <= sigmas * sigma_at_1m * z * z) out[x] = 255;
    }
  }
  return same;
}

double ChangedDepthFraction(const cv::Mat& a, const cv::Mat& b, double sigma_at_1m, double sigmas) {
  RELUME_CHECK(a.type() == CV_32FC1 && b.type() == CV_32FC1 && a.size() == b.size());
  int considered = 0;
  for (int y = 0; y < a.rows; ++y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    for (int x = 0; x < a.cols; ++x) considered += IsDepthValid(pa[x]) || IsDepthValid(pb[x]);
  }
  if (considered == 0) return 0.0;
  const int unchanged = cv::countNonZero(UnchangedDepthMask(a, b, sigma_at_1m, sigmas));
  return static_cast<double>(considered - unchanged) / considered;
}

DepthFilterDecision DecideDepthFiltering(const cv::Mat& first_depth_m, const ShGeometryOptions& options) {
  DepthFilterDecision d;
  d.filter = options.filter_depth;
  if (!options.filter_depth || options.skip_filter_below_at_1m_m <= 0.0) return d;
  // The whole frame, whatever region a caller needs: a small region has too few usable windows
  // between its silhouettes for NoiseFree (the quick smooth suite: p90 14 -> 23 %).
  d.noise = EstimateDepthNoise(first_depth_m);
  d.filter = !d.noise->NoiseFree(options.skip_filter_below_at_1m_m);
  return d;
}

ShGeometry EstimateShGeometry(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics, const cv::Mat& region,
                              const ShGeometryOptions& options, const ShGeometry* previous) {
  ThrowIfInvalid(options, "SH geometry options");
  ThrowIfInvalid(intrinsics, "SH geometry intrinsics");
  if (depth_m.type() != CV_32FC1 || intrinsics.width != depth_m.cols || intrinsics.height != depth_m.rows) {
    throw InvalidArgumentError("SH geometry: depth must be CV_32FC1 of the intrinsics' size");
  }
  if (!region.empty() && (region.type() != CV_8UC1 || region.size() != depth_m.size())) {
    throw InvalidArgumentError("SH geometry: the region must be CV_8UC1 of the depth map's size");
  }
  if (previous != nullptr && previous->depth_m.size() != depth_m.size()) previous = nullptr;  // a new stream
  ShGeometry g;
  const cv::Rect full(0, 0, depth_m.cols, depth_m.rows);
  cv::Rect roi = full;
  if (!region.empty()) {
    roi = MaskBounds(region);
    const int margin = options.bilateral.radius_px + options.normals.window_radius_px + 2;
    if (!roi.empty())
      roi = cv::Rect(roi.x - margin, roi.y - margin, roi.width + 2 * margin, roi.height + 2 * margin) & full;
  }
  g.roi = roi;

  // The stream's filter decision: made on its first frame, inherited after it.
  if (previous != nullptr) {
    g.depth_filtered = options.filter_depth && (options.skip_filter_below_at_1m_m <= 0.0 || previous->depth_filtered);
  } else {
    DepthFilterDecision decision = DecideDepthFiltering(depth_m, options);
    g.depth_filtered = decision.filter;
    g.depth_noise = std::move(decision.noise);
  }
  const bool filter = g.depth_filtered;

  // Depth: bilateral on the crop, temporal on the full frame (NaN outside the crop).
  if (roi == full) {
    g.bilateral_m = filter ? BilateralFilterDepth(depth_m, options.bilateral) : depth_m.clone();
  } else {
    g.bilateral_m = cv::Mat(depth_m.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    if (!roi.empty()) {
      (filter ? BilateralFilterDepth(depth_m(roi), options.bilateral) : depth_m(roi)).copyTo(g.bilateral_m(roi));
    }
  }
  g.depth_m = g.bilateral_m;
  if (filter && previous != nullptr && options.temporal.weight > 0.0) {
    g.depth_m = TemporalFilterDepth(g.bilateral_m, previous->bilateral_m, options.temporal, &g.temporal_blended);
  }

  // Normals: the previous frame's when its depth did not change, else estimated.
  // Normals computed from an unblended first frame are not lent to a blended one: its depth
  // is noisier than the frame's own (the Kinect-noise suite: 17.3 -> 20.0 % median relit error).
  const bool temporal = filter && options.temporal.weight > 0.0;
  if (!options.estimate_normals) {
    g.normals = NormalsOnRoi(g.depth_m, intrinsics, cv::Rect(), options.normals);  // empty maps, none valid
    g.mask = cv::Mat::zeros(depth_m.size(), CV_8UC1);
    return g;
  }
  if (options.normals_reuse && previous != nullptr) {
    g.depth_changed_fraction =
        ChangedDepthFraction(g.depth_m, previous->depth_m, options.bilateral.range_sigma_at_1m_m, options.reuse_sigmas);
    g.normals_reused = *g.depth_changed_fraction <= options.reuse_max_changed_fraction && previous->roi == roi &&
                       (!temporal || previous->temporal_blended > 0);
  }
  if (g.normals_reused) {
    const bool stored = previous->normals.normal_in_camera.empty() && previous->load_normals;
    g.normals = stored ? previous->load_normals() : previous->normals;
    if (g.normals.normal_in_camera.size() != depth_m.size() || g.normals.valid.size() != depth_m.size()) {
      throw InvalidArgumentError("SH geometry: the previous frame's normals are not of the depth map's size");
    }
    g.normals.integral_count = g.normals.cross_count = g.normals.crease_count = g.normals.neighbour_box_count =
        g.normals.jet_count = g.normals.invalid_count = 0;
  } else {
    // Filtered depth is noisy (the reason to filter) and the filter rounds its creases: no
    // crease refinement (its 3 x 3 plane fits would fit the noise) and the neighbours' boxes
    // instead of one-pixel differences (processing/normals.h, "Noisy depth").
    NormalOptions normals = options.normals;
    normals.depth_noisy = normals.depth_noisy || filter;
    if (normals.MeasuresNoise()) {
      // Unfiltered depth is noise-free or not. A stream that measured its first frame has
      // decided that; otherwise (filter_depth off) this frame is measured here, over the whole
      // frame: the roi alone has too few windows for NoiseFree (see DecideDepthFiltering).
      const bool stream_measured = options.filter_depth && options.skip_filter_below_at_1m_m > 0.0;
      if (!stream_measured) {
        DepthNoiseEstimate noise = EstimateDepthNoise(depth_m);
        if (!noise.NoiseFree(normals.refine_creases_below_noise_at_1m_m)) {
          normals.depth_noisy = true;
          if (normals.refine_creases) g.creases_skipped_for_noise = std::move(noise);
        }
      }
      normals.refine_creases_below_noise_at_1m_m = 0.0;
    }
    g.normals = NormalsOnRoi(g.depth_m, intrinsics, roi, normals);
  }
  g.mask = MaskWithDepth(g.normals.valid, g.depth_m);
  return g;
}

ShFrameFit FitShFrameKnownAlbedo(const RadianceImage& radiance, const cv::Mat& normal_in_camera, const cv::Mat& allowed,
                                 const cv::Mat& albedo, const ShFitOptions& options, SamplePointSelector& selector) {
  ShFrameFit out;
  out.samples = selector.Update(allowed);
  out.samples_kept = selector.kept_count();
  out.samples_reselected = selector.reselected_count();
  const ShFitResult fit =
      FitShKnownAlbedo(GatherObservations(radiance, normal_in_camera, albedo, {}, out.samples), options);
  out.light = fit.light;
  out.summary = fit.summary;
  return out;
}

ShFrameFit FitShFrameUnknownAlbedo(const RadianceImage& radiance, const cv::Mat& normal_in_camera,
                                   const cv::Mat& allowed, const SegmentationOptions& segmentation,
                                   const ShAlbedoFitOptions& options, SamplePointSelector& selector) {
  ShFrameFit out;
  out.segmentation = SegmentByColor(radiance, allowed, normal_in_camera, segmentation);
  out.samples = selector.Update(out.segmentation.labels >= 0);
  out.samples_kept = selector.kept_count();
  out.samples_reselected = selector.reselected_count();
  const ShAlbedoFitResult fit = FitShUnknownAlbedo(
      GatherObservations(radiance, normal_in_camera, {}, out.segmentation.labels, out.samples), options);
  out.light = fit.light;
  out.segment_albedo = fit.segment_albedo;
  out.reference_segment = fit.reference_segment;
  out.summary = fit.summary;
  return out;
}

void SetSegmentAlbedo(int segment, const Eigen::Vector3d& albedo, ShFrameFit* fit) {
  if (segment < 0 || static_cast<std::size_t>(segment) >= fit->segment_albedo.size() ||
      !(fit->segment_albedo[static_cast<std::size_t>(segment)].minCoeff() > 0.0)) {
    throw InvalidArgumentError("SH fit: segment " + std::to_string(segment) + " has no albedo to set");
  }
  if (!(albedo.minCoeff() > 0.0) || !albedo.allFinite())
    throw InvalidArgumentError("SH fit: a segment's albedo must be positive and finite");
  const Eigen::Vector3d scale = albedo.cwiseQuotient(fit->segment_albedo[static_cast<std::size_t>(segment)]);
  for (Eigen::Vector3d& a : fit->segment_albedo) a = a.cwiseProduct(scale);
  for (int c = 0; c < 3; ++c) fit->light.col(c) /= scale[c];
  fit->reference_segment = segment;
}

ShFrameFit FitShFrameSharedAlbedo(const RadianceImage& radiance, const cv::Mat& normal_in_camera,
                                  const cv::Mat& allowed, const ShFrameFit& reference, const cv::Mat& same_surface,
                                  const SegmentationOptions& segmentation, const ShFitOptions& options,
                                  SamplePointSelector& selector, const LabelByCentresOptions& labelling) {
  if (reference.segment_albedo.size() != static_cast<std::size_t>(reference.segmentation.segment_count())) {
    throw InvalidArgumentError("SH fit with shared albedo: the reference has " +
                               std::to_string(reference.segment_albedo.size()) + " segment albedo(s) for " +
                               std::to_string(reference.segmentation.segment_count()) +
                               " segment(s); it must be an unknown-albedo fit");
  }
  ShFrameFit out;
  out.segmentation = LabelByCentres(reference.segmentation, radiance, allowed, normal_in_camera, segmentation,
                                    labelling, same_surface);
  const cv::Mat& labels = out.segmentation.labels;
  // Only segments with a positive albedo in every channel are sampled (as WithSegmentAlbedo keeps).
  cv::Mat with_albedo = cv::Mat::zeros(allowed.size(), CV_8UC1);
  for (int y = 0; y < with_albedo.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    auto* w = with_albedo.ptr<std::uint8_t>(y);
    for (int x = 0; x < with_albedo.cols; ++x) {
      w[x] = l[x] >= 0 && reference.segment_albedo[static_cast<std::size_t>(l[x])].minCoeff() > 0.0 ? 255 : 0;
    }
  }
  out.samples = selector.Update(with_albedo);
  out.samples_kept = selector.kept_count();
  out.samples_reselected = selector.reselected_count();
  const ShFitResult fit = FitShKnownAlbedo(
      WithSegmentAlbedo(GatherObservations(radiance, normal_in_camera, {}, out.segmentation.labels, out.samples),
                        reference.segment_albedo),
      options);
  out.light = fit.light;
  out.segment_albedo = reference.segment_albedo;
  out.reference_segment = reference.reference_segment;
  out.summary = fit.summary;
  return out;
}

bool ShEstimatorOptions::IsValid(std::string* why) const {
  return geometry.IsValid(why) && segmentation.IsValid(why) && samples.IsValid(why) && fit.IsValid(why);
}

ShLightEstimator::ShLightEstimator(const ShEstimatorOptions& options)
    : options_((ThrowIfInvalid(options, "SH light estimator"), options)), selector_(options.samples) {}

void ShLightEstimator::Reset() {
  previous_.reset();
  selector_ = SamplePointSelector(options_.samples);
  albedo_reference_.reset();
  albedo_reference_depth_.release();
}

ShFrameEstimate ShLightEstimator::Prepare(const RadianceImage& radiance, const cv::Mat& depth_m,
                                          const PinholeIntrinsics& intrinsics, const cv::Mat& mask) {
  if (radiance.pixels.type() != CV_32FC3 || radiance.pixels.size() != depth_m.size()) {
    throw InvalidArgumentError("SH light estimator: radiance must be RGB float of the depth map's size");
  }
  if (mask.type() != CV_8UC1 || mask.size() != depth_m.size()) {
    throw InvalidArgumentError("SH light estimator: mask must be CV_8UC1 of the depth map's size");
  }
  ThrowIfInvalid(intrinsics, "SH light estimator intrinsics");
  if (intrinsics.width != depth_m.cols || intrinsics.height != depth_m.rows) {
    throw InvalidArgumentError("SH light estimator: intrinsics and depth map differ in size");
  }
  ShGeometry geometry =
      EstimateShGeometry(depth_m, intrinsics, mask, options_.geometry, previous_ ? &*previous_ : nullptr);
  ShFrameEstimate estimate;
  estimate.depth_m = geometry.depth_m;
  estimate.roi = geometry.roi;
  estimate.depth_filtered = geometry.depth_filtered;
  estimate.depth_noise = geometry.depth_noise;
  estimate.normals = geometry.normals;
  estimate.normals_reused = geometry.normals_reused;
  previous_ = std::move(geometry);
  return estimate;
}

void ShLightEstimator::Take(ShFrameFit fit, ShFrameEstimate* estimate) {
  estimate->samples = std::move(fit.samples);
  estimate->samples_kept = fit.samples_kept;
  estimate->samples_reselected = fit.samples_reselected;
  estimate->segmentation = std::move(fit.segmentation);
  estimate->segment_albedo = std::move(fit.segment_albedo);
  estimate->light = fit.light;
  estimate->summary = fit.summary;
}

ShFrameEstimate ShLightEstimator::EstimateKnownAlbedo(const RadianceImage& radiance, const cv::Mat& depth_m,
                                                      const PinholeIntrinsics& intrinsics, const cv::Mat& mask,
                                                      const cv::Mat& albedo) {
  ShFrameEstimate estimate = Prepare(radiance, depth_m, intrinsics, mask);
  Take(FitShFrameKnownAlbedo(radiance, estimate.normals.normal_in_camera, mask & estimate.normals.valid, albedo,
                             options_.fit.fit, selector_),
       &estimate);
  return estimate;
}

ShFrameEstimate ShLightEstimator::EstimateWithReferenceSegment(const RadianceImage& radiance, const cv::Mat& depth_m,
                                                               const PinholeIntrinsics& intrinsics, const cv::Mat& mask,
                                                               const Eigen::Vector3d& reference_albedo) {
  ShFrameEstimate estimate = Prepare(radiance, depth_m, intrinsics, mask);
  estimate.segmentation =
      SegmentByColor(radiance, mask & estimate.normals.valid, estimate.normals.normal_in_camera, options_.segmentation);
  if (estimate.segmentation.segment_count() == 0) {
    estimate.summary.message = "no usable pixels in the mask to segment";
    return estimate;
  }
  estimate.samples = selector_.Update(SegmentMask(estimate.segmentation, 0));
  estimate.samples_kept = selector_.kept_count();
  estimate.samples_reselected = selector_.reselected_count();
  std::vector<ShObservation> observations =
      GatherObservations(radiance, estimate.normals.normal_in_camera, {}, {}, estimate.samples);
  for (ShObservation& o : observations) o.albedo = reference_albedo;
  const ShFitResult fit = FitShKnownAlbedo(observations, options_.fit.fit);
  estimate.light = fit.light;
  estimate.summary = fit.summary;
  return estimate;
}

ShFrameEstimate ShLightEstimator::EstimateUnknownAlbedo(const RadianceImage& radiance, const cv::Mat& depth_m,
                                                        const PinholeIntrinsics& intrinsics, const cv::Mat& mask) {
  ShFrameEstimate estimate = Prepare(radiance, depth_m, intrinsics, mask);
  const cv::Mat allowed = mask & estimate.normals.valid;
  if (options_.share_albedo && albedo_reference_) {
    const cv::Mat same_surface =
        UnchangedDepthMask(albedo_reference_depth_, estimate.depth_m, options_.geometry.bilateral.range_sigma_at_1m_m,
                           options_.geometry.reuse_sigmas);
    Take(FitShFrameSharedAlbedo(radiance, estimate.normals.normal_in_camera, allowed, *albedo_reference_, same_surface,
                                options_.segmentation, options_.fit.fit, selector_),
         &estimate);
    estimate.albedo_shared = true;
    return estimate;
  }
  ShFrameFit fit = FitShFrameUnknownAlbedo(radiance, estimate.normals.normal_in_camera, allowed, options_.segmentation,
                                           options_.fit, selector_);
  if (options_.share_albedo && fit.summary.usable) {
    albedo_reference_ = fit;
    albedo_reference_depth_ = estimate.depth_m.clone();
  }
  Take(std::move(fit), &estimate);
  return estimate;
}

}  // namespace relume::processing
