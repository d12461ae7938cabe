// Checks shared by everything that takes an exposure bracket (response recovery, HDR merge):
// frames of one static scene, same size and sample type, with one positive exposure each.
#pragma once

#include <vector>

#include "core/image.h"

namespace relume::calibration {

// Throws InvalidArgumentError naming the frame and what is wrong: no frames, counts differ,
// a frame invalid, sizes/types/layout/levels differ between frames, exposure not finite > 0.
void CheckBracket(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s);

// Frame indices sorted by exposure time, shortest first (stable for duplicates).
std::vector<int> OrderByExposure(const std::vector<double>& exposure_times_s);

}  // namespace relume::calibration
