// Fitting a camera's colour to a ColorChecker: a per-channel piecewise-linear gain from the
// six neutral patches (Troccoli & Allen: linearises what the response left and sets the
// white balance), then a 3x3 colour correction matrix (CCM) by least squares in linear RGB,
// and CIEDE2000 colour differences per patch.
//
// Conventions:
//  - Measured values are what SamplePatches returned: camera codes scaled to [0, 1] or merged
//    radiance. After gain and CCM they are in "chart reflectance" units of linear sRGB (D65):
//    a white patch under the chart's light maps to its reference reflectance (~0.9).
//  - The gain of channel c is a piecewise-linear, non-decreasing function through (0, 0) and
//    one knot per usable neutral patch (measured, reference), extended beyond the brightest
//    knot with the slope of the last segment.
//  - Delta E 2000 compares L*a*b* (D50, via Bradford from linear sRGB D65) of the corrected
//    patch with the reference L*a*b*.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "calibration/colorchecker_detect.h"
#include "core/color.h"

namespace relume::calibration {

// CIEDE2000 colour difference (Sharma, Wu & Dalal 2005), kL = kC = kH = 1.
double DeltaE2000(const Lab& a, const Lab& b);

struct PiecewiseLinearGain {
  // Per channel: knots x (measured, ascending) and y (linear); empty = identity.
  std::array<std::vector<double>, 3> x, y;
  double Apply(int channel, double value) const;
  bool IsIdentity() const { return x[0].empty() && x[1].empty() && x[2].empty(); }
};

struct ColorFitOptions {
  bool fit_gain = true;
  bool fit_matrix = true;
  bool white_preserving = true;  // the CCM maps the white patch (gain-corrected) exactly
  // Ridge toward the identity, relative to the mean squared value of the patches: keeps the
  // matrix defined when the patches do not span the colour space.
  double ridge = 1e-4;
  double max_condition = 100.0;   // above: low confidence (a full chart gives ~5-10)
  double max_mean_delta_e = 5.0;  // above: low confidence (e.g. an unevenly lit chart)
  bool IsValid(std::string* why) const;
};

struct PatchFit {
  PatchStatus status = PatchStatus::kOk;
  bool used = false;
  Eigen::Vector3d measured = Eigen::Vector3d::Zero();
  Eigen::Vector3d corrected = Eigen::Vector3d::Zero();
  Lab corrected_lab = Lab::Zero();
  double delta_e = 0.0;  // 0 for unused patches
};

struct ColorFitSummary {
  bool usable = false;
  bool low_confidence = false;
  int patches_used = 0;
  int neutrals_used = 0;
  double condition = 0.0;     // of the CCM's least-squares system (singular value ratio)
  double residual_rms = 0.0;  // linear RGB, over used patches
  double mean_delta_e = 0.0;  // over used patches
  double max_delta_e = 0.0;
  // Delta E 2000 of each patch after the fit, 24 in reading order; NaN for a patch not used.
  std::vector<double> patch_delta_e;
  std::string reason;
  std::string BriefReport() const;
};

struct ColorFit {
  PiecewiseLinearGain gain;
  Eigen::Matrix3d ccm = Eigen::Matrix3d::Identity();
  std::vector<PatchFit> patches;  // 24, reading order
  ColorFitSummary summary;

  // measured -> gain -> CCM.
  Eigen::Vector3d Correct(const Eigen::Vector3d& measured) const;
};

// Fits gain and CCM to sampled patches (24, reading order). Patches whose status is not kOk
// are left out and said so in the summary; too few usable patches give usable = false.
ColorFit FitColorChecker(const std::vector<PatchSample>& patches, const ColorCheckerReference& reference,
                         const ColorFitOptions& options = {});

}  // namespace relume::calibration
