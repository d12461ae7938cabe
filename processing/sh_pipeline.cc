#include "processing/sh_pipeline.h"

#include <opencv2/core.hpp>

#include "core/error.h"

namespace relume::processing {

bool ShEstimatorOptions::IsValid(std::string* why) const {
  return bilateral.IsValid(why) && temporal.IsValid(why) && normals.IsValid(why) && segmentation.IsValid(why) &&
         samples.IsValid(why) && fit.IsValid(why);
}

ShLightEstimator::ShLightEstimator(const ShEstimatorOptions& options)
    : options_((ThrowIfInvalid(options, "SH light estimator"), options)),
      denoiser_(options.bilateral, options.temporal),
      selector_(options.samples) {}

void ShLightEstimator::Reset() {
  denoiser_.Reset();
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
  ShFrameEstimate estimate;
  estimate.depth_m = options_.filter_depth ? denoiser_.Process(depth_m) : depth_m;
  estimate.normals = EstimateNormals(estimate.depth_m, intrinsics, options_.normals);
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
