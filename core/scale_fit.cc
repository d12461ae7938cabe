#include "core/scale_fit.h"

#include <algorithm>
#include <cmath>

namespace relume {

void ScaleFitter::Add(double value, double reference) {
  if (!std::isfinite(value) || !std::isfinite(reference) || !(value > 0.0) || !(reference > 0.0)) return;
  const double q = value / reference;
  vr_ += value * reference;
  vv_ += value * value;
  q_ += q;
  qq_ += q * q;
  ++samples_;
}

ScaleFit ScaleFitter::Fit(long long min_samples) const {
  ScaleFit fit;
  fit.samples = samples_;
  if (samples_ < std::max(1LL, min_samples) || !(vv_ > 0.0)) {
    fit.reason = "fewer than " + std::to_string(std::max(1LL, min_samples)) + " positive pairs in common (" +
                 std::to_string(samples_) + ")";
    return fit;
  }
  fit.scale = vr_ / vv_;
  // sum ((a v - r) / r)^2 = a^2 sum q^2 - 2 a sum q + n, with q = v / r.
  const double sum = fit.scale * fit.scale * qq_ - 2.0 * fit.scale * q_ + static_cast<double>(samples_);
  fit.relative_rms = std::sqrt(std::max(0.0, sum) / static_cast<double>(samples_));
  fit.usable = true;
  return fit;
}

}  // namespace relume
