#include "processing/sh_pipeline.h"

#include <algorithm>
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

}  // namespace

bool ShEstimatorOptions::IsValid(std::string* why) const {
  return bilateral.IsValid(why) && temporal.IsValid(why) && normals.IsValid(why) && segmentation.IsValid(why) &&
         samples.IsValid(why) && fit.IsValid(why);
}

ShLightEstimator::ShLightEstimator(const ShEstimatorOptions& options)
    : options_((ThrowIfInvalid(options, "SH light estimator"), options)), selector_(options.samples) {}

void ShLightEstimator::Reset() {
  previous_bilateral_m_.release();
  selector_ = SamplePointSelector(options_.samples);
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
  ShFrameEstimate estimate;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const cv::Rect full(0, 0, depth_m.cols, depth_m.rows);
  cv::Rect roi = MaskBounds(mask);
  const int margin = options_.bilateral.radius_px + options_.normals.window_radius_px + 2;
  if (!roi.empty())
    roi = cv::Rect(roi.x - margin, roi.y - margin, roi.width + 2 * margin, roi.height + 2 * margin) & full;
  estimate.roi = roi;

  // Depth: bilateral on the crop, temporal on the full frame (cheap; NaN outside the crop).
  estimate.depth_m = cv::Mat(depth_m.size(), CV_32FC1, cv::Scalar(nan));
  if (!roi.empty()) {
    if (options_.filter_depth) {
      BilateralFilterDepth(depth_m(roi), options_.bilateral).copyTo(estimate.depth_m(roi));
    } else {
      depth_m(roi).copyTo(estimate.depth_m(roi));
    }
  }
  if (options_.filter_depth) {
    const cv::Mat bilateral = estimate.depth_m;
    if (previous_bilateral_m_.size() != bilateral.size()) previous_bilateral_m_.release();
    estimate.depth_m = TemporalFilterDepth(bilateral, previous_bilateral_m_, options_.temporal);
    previous_bilateral_m_ = bilateral;
  }

  // Normals on the crop, with the principal point moved to it, pasted into full-size maps.
  NormalMap& normals = estimate.normals;
  normals.normal_in_camera = cv::Mat(depth_m.size(), CV_32FC3, cv::Scalar(nan, nan, nan));
  normals.valid = cv::Mat::zeros(depth_m.size(), CV_8UC1);
  normals.method = cv::Mat::zeros(depth_m.size(), CV_8UC1);
  if (!roi.empty()) {
    PinholeIntrinsics crop = intrinsics;
    crop.width = roi.width;
    crop.height = roi.height;
    crop.cx -= roi.x;
    crop.cy -= roi.y;
    const NormalMap part = EstimateNormals(estimate.depth_m(roi), crop, options_.normals);
    part.normal_in_camera.copyTo(normals.normal_in_camera(roi));
    part.valid.copyTo(normals.valid(roi));
    part.method.copyTo(normals.method(roi));
    normals.integral_count = part.integral_count;
    normals.cross_count = part.cross_count;
    normals.invalid_count = part.invalid_count;
  }
  return estimate;
}

void ShLightEstimator::Sample(const cv::Mat& allowed, ShFrameEstimate* estimate) {
  estimate->samples = selector_.Update(allowed);
  estimate->samples_kept = selector_.kept_count();
  estimate->samples_reselected = selector_.reselected_count();
}

ShFrameEstimate ShLightEstimator::EstimateKnownAlbedo(const RadianceImage& radiance, const cv::Mat& depth_m,
                                                      const PinholeIntrinsics& intrinsics, const cv::Mat& mask,
                                                      const cv::Mat& albedo) {
  ShFrameEstimate estimate = Prepare(radiance, depth_m, intrinsics, mask);
  Sample(mask & estimate.normals.valid, &estimate);
  const ShFitResult fit = FitShKnownAlbedo(
      GatherObservations(radiance, estimate.normals.normal_in_camera, albedo, {}, estimate.samples), options_.fit.fit);
  estimate.light = fit.light;
  estimate.summary = fit.summary;
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
  Sample(SegmentMask(estimate.segmentation, 0), &estimate);
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
  estimate.segmentation =
      SegmentByColor(radiance, mask & estimate.normals.valid, estimate.normals.normal_in_camera, options_.segmentation);
  Sample(estimate.segmentation.labels >= 0, &estimate);
  const ShAlbedoFitResult fit = FitShUnknownAlbedo(GatherObservations(radiance, estimate.normals.normal_in_camera, {},
                                                                      estimate.segmentation.labels, estimate.samples),
                                                   options_.fit);
  estimate.light = fit.light;
  estimate.segment_albedo = fit.segment_albedo;
  estimate.summary = fit.summary;
  return estimate;
}

}  // namespace relume::processing
