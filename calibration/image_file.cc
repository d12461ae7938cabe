#include "calibration/image_file.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "calibration/demosaic.h"
#include "core/error.h"

namespace relume::calibration {

bool IsRawFileName(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return !ext.empty() && IsRawFormat(std::string_view(ext).substr(1));
}

LoadedFrame LoadFrame(const std::string& path) {
  LoadedFrame out;
  if (IsRawFileName(path)) {
    RawFile raw = LoadRawFile(path);
    out.image = raw.image.layout == ColorLayout::kMono ? raw.image : DemosaicBilinear(raw.image);
    out.exposure_time_s = raw.exposure_time_s;
    return out;
  }
  if (!std::filesystem::exists(path)) throw IoError(path, "does not exist");
  cv::Mat pixels = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (pixels.empty()) throw IoError(path, "is not an image OpenCV can read");
  if (pixels.depth() != CV_8U && pixels.depth() != CV_16U) {
    throw IoError(path, "holds float samples: a radiance image, not camera output");
  }
  if (pixels.channels() == 4) cv::cvtColor(pixels, pixels, cv::COLOR_BGRA2BGR);
  if (pixels.channels() == 3) cv::cvtColor(pixels, pixels, cv::COLOR_BGR2RGB);
  CameraImage& image = out.image;
  image.pixels = pixels;
  image.layout = pixels.channels() == 3 ? ColorLayout::kRgb : ColorLayout::kMono;
  image.encoding = SampleEncoding::kCameraResponse;
  image.bits_per_sample = pixels.depth() == CV_8U ? 8 : 16;
  image.black_level = 0;
  image.white_level = (1 << image.bits_per_sample) - 1;
  return out;
}

RadianceImage LoadRadianceExr(const std::string& path) {
  if (!std::filesystem::exists(path)) throw IoError(path, "does not exist");
  cv::Mat pixels = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (pixels.empty() || pixels.depth() != CV_32F) throw IoError(path, "is not a float (EXR) image");
  if (pixels.channels() == 4) cv::cvtColor(pixels, pixels, cv::COLOR_BGRA2BGR);
  if (pixels.channels() == 3) cv::cvtColor(pixels, pixels, cv::COLOR_BGR2RGB);
  RadianceImage out;
  out.pixels = pixels;
  return out;
}

void CheckRadianceFileName(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext != ".exr" && ext != ".tif" && ext != ".tiff" && ext != ".pfm") {
    throw InvalidArgumentError(path + ": radiance is floating point; write it as .exr (or .tiff, .pfm), not as '" +
                               ext + "', which would round it to integers");
  }
}

ExrCompression ParseExrCompression(const std::string& text) {
  if (text == "zip") return ExrCompression::kZip;
  if (text == "none") return ExrCompression::kNone;
  if (text == "piz") return ExrCompression::kPiz;
  throw InvalidArgumentError("EXR compression '" + text + "': expected none, zip or piz");
}

void SaveRadianceExr(const RadianceImage& radiance, const std::string& path, ExrCompression compression) {
  CheckRadianceFileName(path);
  std::vector<int> params;
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".exr") {
    params = {cv::IMWRITE_EXR_COMPRESSION, compression == ExrCompression::kNone  ? cv::IMWRITE_EXR_COMPRESSION_NO
                                           : compression == ExrCompression::kPiz ? cv::IMWRITE_EXR_COMPRESSION_PIZ
                                                                                 : cv::IMWRITE_EXR_COMPRESSION_ZIP};
  }
  cv::Mat bgr;
  if (radiance.pixels.channels() == 3) {
    cv::cvtColor(radiance.pixels, bgr, cv::COLOR_RGB2BGR);
  } else {
    bgr = radiance.pixels;
  }
  bool ok = false;
  try {
    ok = cv::imwrite(path, bgr, params);
  } catch (const cv::Exception& e) {
    throw IoError(path, std::string("cannot be written: ") + e.what());
  }
  if (!ok) throw IoError(path, "cannot be written");
}

void SaveImage(const cv::Mat& image, const std::string& path) {
  cv::Mat out;  // not a header on `image`: converting into one would swap the caller's pixels
  if (image.channels() == 3) {
    cv::cvtColor(image, out, cv::COLOR_RGB2BGR);
  } else {
    out = image;
  }
  bool ok = false;
  try {
    ok = cv::imwrite(path, out);
  } catch (const cv::Exception& e) {
    throw IoError(path, std::string("cannot be written: ") + e.what());
  }
  if (!ok) throw IoError(path, "cannot be written");
}

}  // namespace relume::calibration
