// Image types shared by every layer.
//
// Conventions (stated once, here):
//  - Pixel (x, y): x is the column, y the row, origin at the top-left; pixel (x, y) covers
//    [x, x+1) x [y, y+1), so its centre is at (x + 0.5, y + 0.5).
//  - Colour channels are stored R, G, B in that order (not OpenCV's BGR). Conversions to and
//    from OpenCV's file I/O happen at the file edge only.
//  - Two types keep linear and encoded values apart:
//      CameraImage: what a sensor or camera delivered, 8 or 16 bits per sample, either linear
//        sensor counts (raw: value = black_level + k * exposure) or encoded by an unknown or
//        non-linear camera response (JPEG, video). It is never averaged, scaled or divided:
//        it must be linearised first (calibration/).
//      RadianceImage: linear float32, proportional to scene radiance; arithmetic is allowed.
//        `unit` says whether values are relative (up to one global scale) or absolute.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

namespace relume {

enum class ColorLayout {
  kMono,
  kRgb,
  kBayerRggb,
  kBayerBggr,
  kBayerGrbg,
  kBayerGbrg,
};
const char* ToString(ColorLayout layout);
int ChannelCount(ColorLayout layout);  // 1 for mono and Bayer mosaics, 3 for RGB

enum class SampleEncoding {
  kSensorLinear,    // raw sensor counts, linear in exposure above black_level
  kCameraResponse,  // passed through a camera response curve (unknown until calibrated)
};
const char* ToString(SampleEncoding encoding);

struct CameraImage {
  cv::Mat pixels;  // CV_8UC1, CV_8UC3, CV_16UC1 or CV_16UC3; channel count matches layout
  ColorLayout layout = ColorLayout::kRgb;
  SampleEncoding encoding = SampleEncoding::kCameraResponse;
  int bits_per_sample = 8;  // significant bits: 8, 10, 12, 14 or 16 (stored in 8 or 16 bits)
  int black_level = 0;      // counts that mean "no light"
  int white_level = 255;    // counts at and above which a sample is saturated

  int width() const { return pixels.cols; }
  int height() const { return pixels.rows; }
  // False with the reason when storage, layout, bit depth and levels disagree.
  bool IsValid(std::string* why) const;
};

enum class RadianceUnit {
  kRelative,         // proportional to radiance, one unknown global scale
  kWattsPerSqmPerSr  // absolute spectral-band radiance, W m^-2 sr^-1
};

struct RadianceImage {
  cv::Mat pixels;  // CV_32FC3 (RGB) or CV_32FC1; linear; NaN marks "no value" (masked)
  RadianceUnit unit = RadianceUnit::kRelative;

  int width() const { return pixels.cols; }
  int height() const { return pixels.rows; }
  bool IsValid(std::string* why) const;
};

// Allocates a zeroed RGB radiance image.
RadianceImage MakeRadianceImage(int width, int height, RadianceUnit unit = RadianceUnit::kRelative);

}  // namespace relume
