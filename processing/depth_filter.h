// Depth denoising before normals (Ogura & Saito 2015, eqs. 1 and 2): an edge-preserving
// bilateral filter, then a two-frame temporal filter.
//
// Conventions:
//  - Depth maps are CV_32FC1 in metres along the camera's optical axis (z); NaN (or any
//    value <= 0 or infinite) is a hole. Holes stay holes: no pixel is ever filled.
//  - The range sigma grows with the square of depth, like structured-light noise:
//    sigma_r(z) = range_sigma_at_1m_m * z^2 (metres), evaluated at the centre pixel.
//  - A neighbour whose depth differs from the centre by more than edge_cut_sigmas * sigma_r(z)
//    gets weight 0, so no pixel averages across a depth discontinuity (the Gaussian alone
//    would still leak a little).
#pragma once

#include <cmath>
#include <opencv2/core/mat.hpp>
#include <string>

namespace relume::processing {

// A depth sample is a surface point: finite and in front of the camera (NaN, zero, negative
// and infinite values are holes). Every depth step in processing/ uses this one test.
inline bool IsDepthValid(float z) {
  return std::isfinite(z) && z > 0.0f;
}

struct BilateralDepthOptions {
  int radius_px = 1;                   // window (2 r + 1)^2; r = 1 relit best in sh_benchmark
  double spatial_sigma_px = 1.0;       // spatial Gaussian
  double range_sigma_at_1m_m = 0.005;  // range Gaussian at 1 m; scales with z^2
  double edge_cut_sigmas = 3.0;        // hard cut: neighbours beyond this many range sigmas
  bool IsValid(std::string* why) const;
};

struct TemporalDepthOptions {
  double weight = 1.0;  // w in D = (D_t (w + 1) + D_{t-1} w) / (2 w + 1); 0 disables
  // Frames are blended only where both are valid and differ by at most this many range
  // sigmas (BilateralDepthOptions::range_sigma_at_1m_m * z^2); elsewhere D_t is kept.
  double max_difference_sigmas = 3.0;
  double range_sigma_at_1m_m = 0.005;
  bool IsValid(std::string* why) const;
};

// The depth map's own noise, measured without a reference: fourth differences
// z[-2] - 4 z[-1] + 6 z[0] - 4 z[1] + z[2] along rows and columns cancel any surface that is
// locally a cubic (planes, spheres and slanted faces at sensor resolution) and leave
// sqrt(70) sigma of independent noise. A window is used only when its five samples are valid
// and within edge_jump_fraction of the centre's depth (no silhouette, no crease jump). Each
// difference is divided by sqrt(70) z^2, so the result is the noise at 1 m under the
// structured-light z^2 law (the same unit as range_sigma_at_1m_m): the RMS of the lower 98 %
// of the values, corrected to a Gaussian's sigma. Whole millimetres at 1-1.6 m measure
// ~0.1-0.2 mm, Kinect-like noise ~1.5 mm, exact float depth ~0.
//
// Coarse quantisation fools fourth differences: depth in steps wider than the surface's change
// per pixel (whole millimetres on a gentle slope, a structured-light sensor's disparity steps
// at range) is flat between steps, so most differences are exactly 0 and the steps fail the
// edge test. The estimate therefore also reports the share of sloped horizontal five-sample
// rows (one surface within 10 %, first != last) that hold two exactly equal neighbours -- a
// staircase; smooth float depth has none, a fronto-parallel plane is not sloped -- and how
// many valid pixels had a usable window; NoiseFree() needs all three.
struct DepthNoiseEstimate {
  double sigma_at_1m_m = 0.0;
  int samples = 0;              // fourth differences used; 0: not measurable (sigma_at_1m_m NaN)
  int valid_pixels = 0;         // pixels with depth
  double stair_fraction = 0.0;  // of sloped five-sample rows, those with a stair
  // Below `sigma_at_1m_m`, with stairs in under 10 % of sloped rows and windows on at least
  // half the valid pixels (each pixel has two windows, one per axis).
  bool NoiseFree(double sigma_at_1m_m) const;
  std::string Describe() const;  // noise, windows, pixels and stairs, for decisions
};
DepthNoiseEstimate EstimateDepthNoise(const cv::Mat& depth_m, double edge_jump_fraction = 0.02);
// Below this noise (at 1 m) the SH pipeline skips both filters: there is nothing to denoise,
// and they would only round creases and silhouettes (docs/processing-sh.md).
inline constexpr double kDenoiseSkipBelowAt1mM = 5e-5;

// Bilateral filter of one depth map. Throws InvalidArgumentError for bad options or a
// depth map that is not CV_32FC1.
cv::Mat BilateralFilterDepth(const cv::Mat& depth_m, const BilateralDepthOptions& options = {});

// Eq. 2: blends the current and previous (bilaterally filtered) frames where both are valid
// and close; elsewhere returns the current value. previous may be empty (first frame).
cv::Mat TemporalFilterDepth(const cv::Mat& current_m, const cv::Mat& previous_m, const TemporalDepthOptions& options,
                            int* blended_pixel_count = nullptr);

// The two filters over a stream: keeps the previous bilateral output (D_b(t-1), as in the
// paper, not the previous blended output, so errors do not accumulate).
class DepthDenoiser {
 public:
  DepthDenoiser(const BilateralDepthOptions& bilateral, const TemporalDepthOptions& temporal);
  cv::Mat Process(const cv::Mat& depth_m);
  void Reset() { previous_.release(); }
  int last_blended_pixel_count() const { return last_blended_; }

 private:
  BilateralDepthOptions bilateral_;
  TemporalDepthOptions temporal_;
  cv::Mat previous_;
  int last_blended_ = 0;
};

}  // namespace relume::processing
