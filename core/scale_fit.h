// The least-squares scale between two sets of measurements of the same quantity, a minimising
// sum |a v_i - r_i|^2: a = sum v r / sum v v (Loscos et al., "Low-cost photometric calibration
// for interactive relighting", eq. 3). One implementation for every layer that makes radiance
// consistent: calibration (exposure scales of a bracket, EV-only cameras) and processing
// (per-image radiance scales in reflectance estimation).
//
// Conventions: only pairs where both values are finite and > 0 count (a black or saturated
// sample says nothing about a scale); relative_rms is the RMS of (a v - r) / r over them.
#pragma once

#include <string>

namespace relume {

struct ScaleFit {
  double scale = 1.0;         // 1 when not usable
  long long samples = 0;      // pairs used
  double relative_rms = 0.0;  // of (scale v - r) / r over the pairs used
  bool usable = false;
  std::string reason;  // why not usable
};

// Accumulates pairs one at a time (no storage), so it serves images and patch lists alike.
class ScaleFitter {
 public:
  // Pairs with a non-finite or non-positive member are ignored.
  void Add(double value, double reference);
  long long samples() const { return samples_; }
  // Not usable (scale 1, with the reason) with fewer than `min_samples` pairs.
  ScaleFit Fit(long long min_samples = 1) const;

 private:
  long long samples_ = 0;
  double vr_ = 0.0, vv_ = 0.0;  // sum v r, sum v^2
  double q_ = 0.0, qq_ = 0.0;   // sum v / r, sum (v / r)^2, for relative_rms in one pass
};

}  // namespace relume
