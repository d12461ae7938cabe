// The per-frame SH lighting chain of Ogura & Saito / Ogura et al., wired from the parts in
// this folder: depth denoising -> normals -> (segmentation) -> sample points -> SH fit.
// It keeps the state a stream needs (the previous depth frame, the sample points), so one
// estimator serves one camera stream. Relighting (relight.h) takes its normals and light.
//
// Three ways to handle albedo:
//  - EstimateKnownAlbedo: a per-pixel albedo map is given; samples come from the whole mask.
//  - EstimateWithReferenceSegment (the colour paper): k-means segments the object; samples
//    come from the largest segment, whose reflectance (RGB) is known; they are kept across
//    frames and re-selected where they left the segment.
//  - EstimateUnknownAlbedo (the ISVC paper): k-means segments; samples from every segment;
//    alternating light/albedo fit with the scale fixed by ShAlbedoFitOptions.
//
// Region of interest: filtering and normals run only on the bounding rectangle of the mask,
// grown by the bilateral radius + the normal window + 2 pixels (the intrinsics are shifted
// to the crop). Outside it the filtered depth is NaN and there are no normals: only the
// object is relit, so nothing else is needed, and the chain costs in proportion to the object.
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"
#include "processing/depth_filter.h"
#include "processing/normals.h"
#include "processing/segmentation.h"
#include "processing/sh_fit.h"

namespace relume::processing {

struct ShEstimatorOptions {
  bool filter_depth = true;
  BilateralDepthOptions bilateral;
  TemporalDepthOptions temporal;
  NormalOptions normals;
  SegmentationOptions segmentation;
  SamplePointOptions samples;
  ShAlbedoFitOptions fit;  // fit.fit is used by the known-albedo paths
  bool IsValid(std::string* why) const;
};

struct ShFrameEstimate {
  cv::Mat depth_m;  // after denoising (or the input when filter_depth is false); NaN outside roi
  cv::Rect roi;     // where depth was filtered and normals estimated
  NormalMap normals;
  Segmentation segmentation;  // empty for EstimateKnownAlbedo
  std::vector<cv::Point> samples;
  int samples_kept = 0;  // from the previous frame
  int samples_reselected = 0;
  ShRgb light = ShRgb::Zero();                  // camera frame
  std::vector<Eigen::Vector3d> segment_albedo;  // unknown-albedo path only
  ShFitSummary summary;
};

class ShLightEstimator {
 public:
  explicit ShLightEstimator(const ShEstimatorOptions& options = {});

  // radiance: RGB; depth_m: CV_32FC1 registered to radiance; mask: CV_8UC1 object pixels.
  ShFrameEstimate EstimateKnownAlbedo(const RadianceImage& radiance, const cv::Mat& depth_m,
                                      const PinholeIntrinsics& intrinsics, const cv::Mat& mask, const cv::Mat& albedo);
  ShFrameEstimate EstimateWithReferenceSegment(const RadianceImage& radiance, const cv::Mat& depth_m,
                                               const PinholeIntrinsics& intrinsics, const cv::Mat& mask,
                                               const Eigen::Vector3d& reference_albedo);
  ShFrameEstimate EstimateUnknownAlbedo(const RadianceImage& radiance, const cv::Mat& depth_m,
                                        const PinholeIntrinsics& intrinsics, const cv::Mat& mask);
  void Reset();

 private:
  ShFrameEstimate Prepare(const RadianceImage& radiance, const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics,
                          const cv::Mat& mask);
  void Sample(const cv::Mat& allowed, ShFrameEstimate* estimate);

  ShEstimatorOptions options_;
  cv::Mat previous_bilateral_m_;  // D_b(t-1) for the temporal filter, full frame
  SamplePointSelector selector_;
};

}  // namespace relume::processing
