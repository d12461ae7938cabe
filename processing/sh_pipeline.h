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
#include <functional>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"
#include "processing/depth_filter.h"
#include "processing/normals.h"
#include "processing/segmentation.h"
#include "processing/sh_fit.h"

namespace relume::processing {

// ---- The chain's steps ---------------------------------------------------------------------
// Each step is a function of its inputs and, where a stream needs it, the previous frame's
// result. ShLightEstimator strings them together for a stream held in memory; `relume process
// --pipeline sh` (pipeline/sh_pipeline.cc) runs each as a cached stage whose previous frame it
// reads back from disk. Both run this code, so what `relume bench` measures is what a session
// is processed with.

struct ShGeometryOptions {
  bool filter_depth = true;  // bilateral, then temporal against the previous frame's bilateral
  // With filter_depth on, the stream decides once, on its first frame (previous == nullptr):
  // when that frame's own noise (EstimateDepthNoise over the whole frame, at 1 m) is NoiseFree below
  // this, neither it nor the frames after it (they inherit ShGeometry::depth_filtered) are
  // filtered. On noise-free depth the filters only round creases and silhouettes, and the
  // normals then refine creases: the analytic SH scene relights 0.69 % off unfiltered, 1.58 %
  // filtered (sh_accuracy_test.cc; 0.61 / 1.96 % relit by each pixel's own ratio). Whole
  // millimetres (~0.1-0.2 mm) and Kinect noise (~1.5 mm) stay filtered. 0: filter whatever the
  // noise (a caller that has decided already).
  double skip_filter_below_at_1m_m = kDenoiseSkipBelowAt1mM;
  BilateralDepthOptions bilateral;
  TemporalDepthOptions temporal;
  NormalOptions normals;  // normals.refine_creases applies only where depth is not filtered
  // The previous frame's normals are kept when at most reuse_max_changed_fraction of the pixels
  // with depth in either frame appeared, vanished or moved by more than reuse_sigmas range
  // sigmas (bilateral.range_sigma_at_1m_m z^2): a static camera on a static scene. With the
  // temporal filter on, only a frame the filter blended lends its normals (the stream's first
  // frame has nothing to blend with, and its normals are noisier).
  bool normals_reuse = true;
  double reuse_sigmas = 3.0;
  double reuse_max_changed_fraction = 0.005;
  // false: depth only; the normals are left empty (no normal valid) for a caller that brings
  // its own (the pipeline's true-normals diagnostic), and no frame's normals are reused.
  bool estimate_normals = true;
  bool IsValid(std::string* why) const;
};

// One frame's geometry, and the state the next frame's step reads.
struct ShGeometry {
  cv::Mat bilateral_m;  // the bilateral filter's output (the input when not filtering): D_b(t)
  cv::Mat depth_m;      // after both filters (the input when not filtering); NaN outside roi
  cv::Rect roi;         // where depth was filtered and normals estimated
  NormalMap normals;    // full-frame maps (the previous frame's when reused)
  // As `previous`, a frame whose normals are empty reads them through this on demand, only when
  // they are reused (a stage folder read back: most frames never need its normals).
  std::function<NormalMap()> load_normals;
  cv::Mat mask;                 // CV_8UC1: a valid normal and depth
  bool depth_filtered = false;  // the stream's filter decision (ShGeometryOptions::filter_depth)
  // The noise measured for the decision: a stream's first frame, when it was decided here.
  std::optional<DepthNoiseEstimate> depth_noise;
  // Depth not filtered (filter_depth off) but measured noisy: no crease refinement
  // (NormalOptions::refine_creases_below_noise_at_1m_m), and how noisy.
  std::optional<DepthNoiseEstimate> creases_skipped_for_noise;
  int temporal_blended = 0;
  std::optional<double> depth_changed_fraction;  // normals_reuse with a previous frame
  bool normals_reused = false;
};

// A stream's filter decision (ShGeometryOptions::skip_filter_below_at_1m_m), made on its first
// depth frame over the whole frame: filter unless filter_depth is off or the frame measures
// noise-free. `noise` holds the measurement when one was made (filter_depth on and a positive
// threshold). EstimateShGeometry calls it on a stream's first frame; a caller that runs the
// frames as separate steps (the sh pipeline's cached stages) calls it once and passes the
// decision on with the threshold cleared.
struct DepthFilterDecision {
  bool filter = true;
  std::optional<DepthNoiseEstimate> noise;
};
DepthFilterDecision DecideDepthFiltering(const cv::Mat& first_depth_m, const ShGeometryOptions& options);

// depth_m: CV_32FC1 metres in the colour camera (intrinsics' size). region: CV_8UC1, the pixels
// that need normals (empty: the whole frame): filtering and normals run on its bounding
// rectangle grown by the filter's and the normal window's reach (see the top of this file).
// previous: the previous frame's result (nullptr for the first frame of a stream).
ShGeometry EstimateShGeometry(const cv::Mat& depth_m, const PinholeIntrinsics& intrinsics, const cv::Mat& region,
                              const ShGeometryOptions& options, const ShGeometry* previous);

// `valid` (CV_8UC1) without the pixels that have no depth (not finite or not positive).
cv::Mat MaskWithDepth(const cv::Mat& valid, const cv::Mat& depth_m);

// The fraction of the pixels with depth in either map whose depth appeared, vanished or moved
// by more than `sigmas` range sigmas (sigma_at_1m z^2, as a sensor's noise grows).
double ChangedDepthFraction(const cv::Mat& a, const cv::Mat& b, double sigma_at_1m, double sigmas);
// CV_8UC1: 255 where both maps have depth and it moved by at most `sigmas` range sigmas (the
// same surface in both frames of a static view), 0 elsewhere.
cv::Mat UnchangedDepthMask(const cv::Mat& a, const cv::Mat& b, double sigma_at_1m, double sigmas);

struct ShFrameFit {
  ShRgb light = ShRgb::Zero();                  // camera frame
  std::vector<Eigen::Vector3d> segment_albedo;  // unknown albedo only
  int reference_segment = -1;                   // unknown albedo only: the segment that fixed the scale
  Segmentation segmentation;                    // unknown albedo only
  std::vector<cv::Point> samples;
  int samples_kept = 0;  // from the selector's previous frame
  int samples_reselected = 0;
  ShFitSummary summary;
};

// The fit step. allowed: CV_8UC1, pixels that may be sampled (a valid normal, finite radiance);
// the selector keeps its sample points from frame to frame (a fresh one per frame for a step
// that must not depend on the frames before it). albedo: CV_32FC3 per-pixel albedo.
ShFrameFit FitShFrameKnownAlbedo(const RadianceImage& radiance, const cv::Mat& normal_in_camera, const cv::Mat& allowed,
                                 const cv::Mat& albedo, const ShFitOptions& options, SamplePointSelector& selector);
ShFrameFit FitShFrameUnknownAlbedo(const RadianceImage& radiance, const cv::Mat& normal_in_camera,
                                   const cv::Mat& allowed, const SegmentationOptions& segmentation,
                                   const ShAlbedoFitOptions& options, SamplePointSelector& selector);
// Unknown albedo made absolute: segment `segment`'s albedo is `albedo`. Each channel's free scale
// (sh_fit.h) moves to it: the segment albedos are multiplied by albedo / the segment's albedo and
// the light divided by it, so albedo x light, and the fit's residual, stay as they were. Throws
// InvalidArgumentError for a segment without a positive albedo or a non-positive `albedo`.
void SetSegmentAlbedo(int segment, const Eigen::Vector3d& albedo, ShFrameFit* fit);

// Unknown albedo, shared by the frames of one scene: `reference` is another frame's unknown-albedo
// fit (its segmentation with centres and its segment albedos, from FitShFrameUnknownAlbedo with
// the same segmentation options). This frame's pixels are labelled with the reference's
// segments and the light is fitted with their albedos as known:
//  - same_surface (CV_8UC1, may be empty): pixels that show the same surface point as in the
//    reference frame (a static view: UnchangedDepthMask). They keep the reference's label,
//    whatever the light's colour did to their chromaticity;
//  - the other pixels join the reference's segment of the nearest chromaticity (LabelByCentres;
//    a material the reference did not see is left out).
// The albedo-light ambiguity of the unknown-albedo fit is then the same in both frames, so it
// cancels in the ratio of their lights: relighting one frame to the other's light does not
// depend on it (the random SH suites halve their median error this way, docs/processing-sh.md).
// Segments whose reference albedo is not positive in every channel are left out.
ShFrameFit FitShFrameSharedAlbedo(const RadianceImage& radiance, const cv::Mat& normal_in_camera,
                                  const cv::Mat& allowed, const ShFrameFit& reference, const cv::Mat& same_surface,
                                  const SegmentationOptions& segmentation, const ShFitOptions& options,
                                  SamplePointSelector& selector, const LabelByCentresOptions& labelling = {});

// ---- A stream in memory --------------------------------------------------------------------

struct ShEstimatorOptions {
  ShGeometryOptions geometry;  // depth filters, normals and their reuse
  SegmentationOptions segmentation;
  SamplePointOptions samples;
  ShAlbedoFitOptions fit;  // fit.fit is used by the known-albedo paths
  // EstimateUnknownAlbedo: the stream's first usable unknown-albedo fit (after construction or
  // Reset) becomes its albedo reference, and every later frame is fitted with the reference's
  // segment albedos (FitShFrameSharedAlbedo; the same surface by UnchangedDepthMask against the
  // reference's depth, with the bilateral filter's range sigma and the geometry's reuse_sigmas),
  // so that relighting one frame of the stream to another's light does not depend on the
  // albedo-light ambiguity. false: each frame on its own (the ambiguity settled per frame).
  bool share_albedo = true;
  bool IsValid(std::string* why) const;
};

struct ShFrameEstimate {
  cv::Mat depth_m;                                // after denoising (or the input when not filtered); NaN outside roi
  cv::Rect roi;                                   // where depth was filtered and normals estimated
  bool depth_filtered = false;                    // the stream's decision (ShGeometryOptions)
  std::optional<DepthNoiseEstimate> depth_noise;  // measured on the stream's first frame
  NormalMap normals;
  bool normals_reused = false;  // the previous frame's (its depth did not change)
  Segmentation segmentation;    // empty for EstimateKnownAlbedo
  std::vector<cv::Point> samples;
  int samples_kept = 0;  // from the previous frame
  int samples_reselected = 0;
  ShRgb light = ShRgb::Zero();                  // camera frame
  std::vector<Eigen::Vector3d> segment_albedo;  // unknown-albedo path only
  bool albedo_shared = false;                   // fitted with the stream's albedo reference (share_albedo)
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
  static void Take(ShFrameFit fit, ShFrameEstimate* estimate);

  ShEstimatorOptions options_;
  std::optional<ShGeometry> previous_;  // the previous frame's geometry (temporal filter, normals reuse)
  SamplePointSelector selector_;
  std::optional<ShFrameFit> albedo_reference_;  // share_albedo: the first usable unknown-albedo fit
  cv::Mat albedo_reference_depth_;              // and its frame's depth
};

}  // namespace relume::processing
