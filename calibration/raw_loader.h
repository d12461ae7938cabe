// Camera raw files (NEF, CR2, ARW, DNG, ...) through LibRaw: the sensor's counts as they left
// the ADC, with black and white level, no response curve, no white balance, no demosaicing.
//
// Conventions: the result is a CameraImage with encoding kSensorLinear, 16-bit storage, the
// visible area only (LibRaw's margins cropped), layout = the Bayer pattern of the visible
// area's top-left 2 x 2 block (or kMono for sensors without a colour filter array).
// black_level is LibRaw's common black plus the smallest per-channel offset.
#pragma once

#include <string>

#include "core/image.h"

namespace relume::calibration {

struct RawFile {
  CameraImage image;
  double exposure_time_s = 0.0;  // from the file's metadata; 0 when absent
  double aperture_f = 0.0;
  double iso = 0.0;
  std::string make;
  std::string model;
};

// Throws IoError (with LibRaw's message) when the file is missing or not a raw file LibRaw
// can decode, InvalidArgumentError for a layout relume does not handle (e.g. X-Trans, or
// Foveon / linear-RGB DNG).
RawFile LoadRawFile(const std::string& path);

// Bilinear demosaicing of a Bayer CameraImage into a 16-bit RGB CameraImage, still sensor
// linear (interpolation is linear, so black and white levels keep their meaning; a pixel next
// to a clipped one may read slightly below white_level, so merges use a saturation margin).
CameraImage DemosaicBilinear(const CameraImage& bayer);

}  // namespace relume::calibration
