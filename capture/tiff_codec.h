// Lossless TIFF for the frames relume encodes itself (RGB-D depth and colour), written through
// libtiff: one image, horizontal differencing predictor, zstd level 1, strips of 32 rows.
// A 640x480 depth + colour pair encodes in 8.8 ms against 25.1 ms for OpenCV's PNG, and is
// smaller (BM_EncodeRgbd in capture/rgbd_recorder_benchmark.cc; docs/capture.md), which is what
// keeps the RGB-D recorder at 30 fps on two busy cores. Files read with any libtiff >= 4.0.10
// (OpenCV, GDAL, Pillow, tifffile with imagecodecs).
//
// Conventions: `pixels` is CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3, CV_32FC1 or CV_32FC3; three
// channels are in RGB order and are written as RGB (PHOTOMETRIC_RGB), one as grey (MINISBLACK).
// Floats are IEEE samples with the floating-point predictor (depth in metres keeps NaN holes).
// Little-endian.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace relume::capture {

struct TiffOptions {
  enum class Compression { kZstd, kDeflate, kNone };
  Compression compression = Compression::kZstd;
  int level = 1;            // zstd 1..19 or deflate 1..9 (ignored for kNone)
  int rows_per_strip = 32;  // smaller strips decode in parallel; larger ones compress better
  bool IsValid(std::string* why) const;
};

// The file's bytes. Throws InvalidArgumentError for an unsupported Mat type or invalid options,
// IoError when libtiff fails.
std::vector<std::uint8_t> EncodeTiff(const cv::Mat& pixels_rgb_or_mono, const TiffOptions& options = {});

}  // namespace relume::capture
