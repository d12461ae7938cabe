// Reading camera frames and writing radiance images at the file edge (OpenCV imgcodecs,
// LibRaw for raw files). Files hold BGR; relume's images hold RGB (core/image.h).
#pragma once

#include <string>

#include "core/image.h"

namespace relume::calibration {

// True for camera raw extensions (core/raw_file.h IsRawFormat: dng, nef, cr2, cr3, arw, ...).
bool IsRawFileName(const std::string& path);

struct LoadedFrame {
  CameraImage image;             // RGB (raw files demosaiced, sensor linear)
  double exposure_time_s = 0.0;  // from raw metadata; 0 when unknown
};

// PNG/TIFF/JPEG (8 or 16 bit, grey or colour; camera-encoded, white level 2^bits - 1) or a
// raw file. Throws IoError naming the file when it cannot be read.
LoadedFrame LoadFrame(const std::string& path);

// OpenEXR (float RGB) read/write. Throws IoError. Saving also takes .tif/.tiff and .pfm, the
// other formats that keep float radiance; any other extension is refused up front (PNG or
// JPEG would round radiance to 8-bit integers): see CheckRadianceFileName.
RadianceImage LoadRadianceExr(const std::string& path);
// How an .exr is compressed (lossless all): ZIP, OpenCV's default, saves little on photographs'
// noisy floats and costs much (a 1200 x 800 merge: 10.5 MB against 11.5 MB uncompressed, in
// 20x the time: docs/benchmarks.md, "hdr-files"); smooth renders compress far better.
enum class ExrCompression { kZip, kNone, kPiz };
// "zip", "none" or "piz"; throws InvalidArgumentError naming the choices otherwise.
ExrCompression ParseExrCompression(const std::string& text);
void SaveRadianceExr(const RadianceImage& radiance, const std::string& path,
                     ExrCompression compression = ExrCompression::kZip);
// Throws InvalidArgumentError unless `path` names a float image format (.exr, .tif, .tiff, .pfm).
void CheckRadianceFileName(const std::string& path);

// Writes an RGB 8-bit image (PNG) or a CV_16UC1 / CV_8UC1 image. Throws IoError.
void SaveImage(const cv::Mat& image_rgb_or_gray, const std::string& path);

}  // namespace relume::calibration
