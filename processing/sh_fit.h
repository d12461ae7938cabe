// Estimating SH lighting from an RGB-D view of Lambertian surfaces (Ogura & Saito 2015,
// Ogura et al.): I = albedo * E(n) / pi with E(n) = sum_k A_l L_k Y_k(n) (processing/sh.h).
//
//  - Known albedo: one linear least-squares problem per channel for the 9 (or 4, or 1)
//    coefficients, solved from normal equations with Eigen's LDLT.
//  - Unknown albedo: pixels are grouped into segments of uniform albedo (segmentation.h);
//    starting from each segment's mean colour as its albedo, illumination and albedo are
//    updated in turn (each a linear least-squares step) until the coefficients stop changing.
//    The product albedo * light is all the pixels determine, so each channel has one free
//    scale: it is fixed by declaring the reference segment's albedo (largest segment unless
//    told) to be `reference_albedo`. A caller who knows the true albedo of one region
//    gets absolute results; otherwise light and albedos are right up to that per-channel
//    scale, which cancels when source and destination lighting are estimated the same way.
//  - Conditioning: the fit measures how well the normals support each order: the condition
//    number of the orthonormal basis matrix [Y_k(n_i)] (sqrt of the eigenvalue ratio of its
//    Gram matrix) and the solid angle the normals cover (occupied cells of a 16 x 32
//    equal-area grid, 4 pi / 512 sr each). Order 2 needs both thresholds met; otherwise the
//    fit drops to order 1, then to order 0, and the Summary says so and why.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "processing/sh.h"

namespace relume::processing {

// One pixel's data for the fit (camera-frame unit normal, linear RGB radiance).
struct ShObservation {
  Eigen::Vector3d normal;
  Eigen::Vector3d radiance;
  Eigen::Vector3d albedo = Eigen::Vector3d::Ones();  // known-albedo fit only
  int segment = 0;                                   // unknown-albedo fit only
};

// Gathers observations at `points`, skipping pixels without a valid normal, with non-finite
// or negative radiance, or (when given) non-finite albedo or a negative label. albedo
// (CV_32FC3) and labels (CV_32SC1) may be empty.
std::vector<ShObservation> GatherObservations(const RadianceImage& radiance, const cv::Mat& normal_in_camera,
                                              const cv::Mat& albedo, const cv::Mat& labels,
                                              const std::vector<cv::Point>& points);

struct ShFitOptions {
  int max_order = 2;                         // 0, 1 or 2
  double max_condition_number = 150.0;       // per order, on the orthonormal basis matrix
  double min_solid_angle_order2_sr = 1.5;    // normals must cover at least this for order 2
  int min_observations_per_coefficient = 4;  // N >= this * coefficient count
  bool IsValid(std::string* why) const;
};

struct ShFitSummary {
  bool usable = false;         // false: no light estimated (light is zero), see message
  int order_used = -1;         // 0, 1 or 2
  bool order_reduced = false;  // order_used < max_order because the normals did not support it
  int observation_count = 0;
  double condition_number = 0.0;         // of the order actually used
  double condition_number_order2 = 0.0;  // for the record, even when order 2 was dropped
  double normal_solid_angle_sr = 0.0;
  double relative_rms_residual = 0.0;  // rms(I - model) / rms(I) over the observations
  // Unknown albedo only (NaN otherwise): how well the pixels tell the light apart from the
  // segments' albedos, as the condition number of the joint least-squares problem at the
  // solution (reference albedo fixed, unit-diagonal scaling, worst channel). Infinite or huge
  // when segments show too few orientations (flat walls and ground): a segment's albedo then
  // absorbs whatever irradiance its normals receive, the light's direction is not determined
  // by the data, and the fit returns its starting guess (mostly ambient light).
  double albedo_light_condition_number = std::numeric_limits<double>::quiet_NaN();
  int iterations = 0;  // unknown albedo: alternations done (1 for known albedo)
  bool converged = false;
  std::string message;  // how the fit ended, in words
  std::string BriefReport() const;
};

struct ShFitResult {
  ShRgb light = ShRgb::Zero();  // coefficients above order_used are zero
  ShFitSummary summary;
};

// The observations of segments whose albedo (segment_albedo[segment]) is positive, each carrying
// it as its known albedo: another frame's segment albedos used in a known-albedo fit. Throws
// InvalidArgumentError for an observation whose segment has no entry.
std::vector<ShObservation> WithSegmentAlbedo(const std::vector<ShObservation>& observations,
                                             const std::vector<Eigen::Vector3d>& segment_albedo);

// Known albedo. Throws InvalidArgumentError for invalid options; a degenerate input (too few
// observations, normals on one point) is a Summary with usable = false.
ShFitResult FitShKnownAlbedo(const std::vector<ShObservation>& observations, const ShFitOptions& options = {});

struct ShAlbedoFitOptions {
  ShFitOptions fit;
  int max_iterations = 200;
  double tolerance = 1e-7;                // stop when ||L_new - L_old|| / ||L_new|| falls below
  int min_observations_per_segment = 10;  // smaller segments are left out of the fit
  int reference_segment = -1;             // -1: the segment with the most observations
  Eigen::Vector3d reference_albedo = Eigen::Vector3d::Constant(0.5);  // fixes the scale
  bool IsValid(std::string* why) const;
};

struct ShAlbedoFitResult {
  ShRgb light = ShRgb::Zero();
  std::vector<Eigen::Vector3d> segment_albedo;  // per segment label; NaN-free, zero when left out
  std::vector<bool> segment_used;
  int reference_segment = -1;
  ShFitSummary summary;
};

// Unknown albedo: alternating illumination / albedo updates (see the top of this file).
ShAlbedoFitResult FitShUnknownAlbedo(const std::vector<ShObservation>& observations,
                                     const ShAlbedoFitOptions& options = {});

// The normals' coverage, as used by the fits (exposed for tests and reports).
double NormalSolidAngleSr(const std::vector<ShObservation>& observations);
double ShConditionNumber(const std::vector<ShObservation>& observations, int order);

}  // namespace relume::processing
