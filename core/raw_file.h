// Camera raw files (NEF, CR2, CR3, ARW, DNG, ...) decoded through LibRaw: the sensor's counts as
// they left the ADC, with black and white level; no response curve, no white balance, no
// demosaicing. Drivers decode a DSLR's raw file to meter with it, the session reader to give
// processing its pixels, calibration to read raw files from disk; all use this one decoder.
//
// Conventions: the result is a CameraImage with encoding kSensorLinear, CV_16UC1 storage, the
// visible area only (LibRaw's margins cropped), layout = the Bayer pattern of the visible
// area's top-left 2 x 2 block (or kMono for sensors without a colour filter array).
// black_level is LibRaw's common black plus the smallest per-channel offset; white_level is
// LibRaw's maximum; bits_per_sample the fewest bits that hold white_level.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "core/image.h"

namespace relume {

struct RawFile {
  CameraImage image;
  double exposure_time_s = 0.0;  // from the file's metadata; 0 when absent
  double aperture_f = 0.0;
  double iso = 0.0;
  std::string make;
  std::string model;
};

// True for the file formats (lower-case extension without the dot: "nef", "cr3", "dng") that
// are camera raw files, whether or not relume can decode the particular sensor layout.
bool IsRawFormat(std::string_view format);

// Decodes a raw file held in memory. `name` names it in messages (a path or a frame id).
// Throws IoError (with LibRaw's message) when the bytes are not a raw file LibRaw can decode,
// InvalidArgumentError for a sensor layout relume does not handle (X-Trans, Foveon or
// linear-RGB DNG), each saying that the file itself is not affected.
RawFile DecodeRawFile(std::span<const std::uint8_t> bytes, const std::string& name);

// Reads and decodes a raw file on disk. Throws IoError naming the path when it cannot be read.
RawFile LoadRawFile(const std::string& path);

}  // namespace relume
