#include "calibration/bracket.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>

#include "core/error.h"

namespace relume::calibration {

void CheckExposureTime(double t, const std::string& what) {
  if (std::isfinite(t) && t >= kMinExposureTimeS && t <= kMaxExposureTimeS) return;
  char text[160];
  std::snprintf(text, sizeof(text), ": exposure time %g s is %s [%g, %g] s", t,
                std::isfinite(t) && t > 0.0 ? "outside the usable range" : "not a positive number in",
                kMinExposureTimeS, kMaxExposureTimeS);
  throw InvalidArgumentError(what + text);
}

void CheckBracket(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s) {
  if (frames.empty()) throw InvalidArgumentError("bracket: no frames given");
  if (frames.size() != exposure_times_s.size()) {
    throw InvalidArgumentError("bracket: " + std::to_string(frames.size()) + " frames but " +
                               std::to_string(exposure_times_s.size()) + " exposure times; give one per frame");
  }
  const CameraImage& first = frames.front();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const CameraImage& f = frames[i];
    const std::string name = "bracket frame " + std::to_string(i);
    std::string why;
    if (!f.IsValid(&why)) throw InvalidArgumentError(name + ": " + why);
    if (f.pixels.size() != first.pixels.size() || f.pixels.type() != first.pixels.type() || f.layout != first.layout) {
      throw InvalidArgumentError(name +
                                 ": size, sample type or layout differs from frame 0; a bracket must come from " +
                                 "one camera with fixed settings");
    }
    if (f.encoding != first.encoding || f.black_level != first.black_level || f.white_level != first.white_level) {
      throw InvalidArgumentError(name + ": encoding or black/white level differs from frame 0");
    }
    CheckExposureTime(exposure_times_s[i], name);
  }
}

std::vector<int> OrderByExposure(const std::vector<double>& exposure_times_s) {
  std::vector<int> order(exposure_times_s.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return exposure_times_s[a] < exposure_times_s[b]; });
  return order;
}

}  // namespace relume::calibration
