// Demosaicing camera raw frames. Decoding the raw files themselves (LibRaw) is in
// core/raw_file.h, shared with the drivers and the session reader.
#pragma once

#include <string>

#include "core/image.h"
#include "core/raw_file.h"

namespace relume::calibration {

// Bilinear demosaicing of a Bayer CameraImage into a 16-bit RGB CameraImage, still sensor
// linear (interpolation is linear, so black and white levels keep their meaning; a pixel next
// to a clipped one may read slightly below white_level, so merges use a saturation margin).
CameraImage DemosaicBilinear(const CameraImage& bayer);

}  // namespace relume::calibration
