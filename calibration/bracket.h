// Checks shared by everything that takes an exposure bracket (response recovery, HDR merge):
// frames of one static scene, same size and sample type, with one positive exposure each.
#pragma once

#include <string>
#include <vector>

#include "core/image.h"

namespace relume::calibration {

// Exposure times (seconds, or relative exposures) a bracket may have. Radiance is code / t in
// float: below 1e-9 it overflows towards Inf (1e-320 s is Inf), above 1e5 (28 hours) it
// underflows towards zero (1e308 s gives zeros). Real shutters span about 1e-5 .. 1e3 s.
inline constexpr double kMinExposureTimeS = 1e-9;
inline constexpr double kMaxExposureTimeS = 1e5;

// Throws InvalidArgumentError "<what>: exposure time T s is ..." unless T is finite and within
// [kMinExposureTimeS, kMaxExposureTimeS].
void CheckExposureTime(double exposure_time_s, const std::string& what);

// Throws InvalidArgumentError naming the frame and what is wrong: no frames, counts differ,
// a frame invalid, sizes/types/layout/levels differ between frames, an exposure time that
// CheckExposureTime refuses.
void CheckBracket(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s);

// Frame indices sorted by exposure time, shortest first (stable for duplicates).
std::vector<int> OrderByExposure(const std::vector<double>& exposure_times_s);

}  // namespace relume::calibration
