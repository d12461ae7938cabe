#include "core/image.h"

#include <opencv2/core.hpp>

namespace relume {

const char* ToString(ColorLayout layout) {
  switch (layout) {
    case ColorLayout::kMono: return "mono";
    case ColorLayout::kRgb: return "rgb";
    case ColorLayout::kBayerRggb: return "bayer_rggb";
    case ColorLayout::kBayerBggr: return "bayer_bggr";
    case ColorLayout::kBayerGrbg: return "bayer_grbg";
    case ColorLayout::kBayerGbrg: return "bayer_gbrg";
  }
  return "unknown";
}

int ChannelCount(ColorLayout layout) {
  return layout == ColorLayout::kRgb ? 3 : 1;
}

const char* ToString(SampleEncoding encoding) {
  switch (encoding) {
    case SampleEncoding::kSensorLinear: return "sensor_linear";
    case SampleEncoding::kCameraResponse: return "camera_response";
  }
  return "unknown";
}

namespace {
bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}
}  // namespace

bool CameraImage::IsValid(std::string* why) const {
  if (pixels.empty()) return Fail(why, "image has no pixels");
  const int depth = pixels.depth();
  if (depth != CV_8U && depth != CV_16U) return Fail(why, "camera samples must be 8- or 16-bit unsigned");
  if (pixels.channels() != ChannelCount(layout)) {
    return Fail(why, std::string("layout ") + ToString(layout) + " needs " + std::to_string(ChannelCount(layout)) +
                         " channel(s), image has " + std::to_string(pixels.channels()));
  }
  const int storage_bits = depth == CV_8U ? 8 : 16;
  if (bits_per_sample < 8 || bits_per_sample > storage_bits) {
    return Fail(why, "bits_per_sample " + std::to_string(bits_per_sample) + " does not fit in " +
                         std::to_string(storage_bits) + "-bit storage");
  }
  const int max_value = (1 << bits_per_sample) - 1;
  if (black_level < 0 || white_level > max_value || black_level >= white_level) {
    return Fail(why, "need 0 <= black_level < white_level <= " + std::to_string(max_value) + " (got " +
                         std::to_string(black_level) + ", " + std::to_string(white_level) + ")");
  }
  return true;
}

bool RadianceImage::IsValid(std::string* why) const {
  if (pixels.empty()) return Fail(why, "image has no pixels");
  if (pixels.type() != CV_32FC3 && pixels.type() != CV_32FC1) {
    return Fail(why, "radiance must be float32 with 1 or 3 channels");
  }
  return true;
}

RadianceImage MakeRadianceImage(int width, int height, RadianceUnit unit) {
  RadianceImage image;
  image.pixels = cv::Mat::zeros(height, width, CV_32FC3);
  image.unit = unit;
  return image;
}

}  // namespace relume
