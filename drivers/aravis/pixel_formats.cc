#include "drivers/aravis/pixel_formats.h"

#include <array>
#include <cstdio>
#include <cstring>
#include <opencv2/core.hpp>

#include "drivers/device_error.h"

namespace relume::drivers::aravis {
namespace {

// PFNC codes (GenICam Pixel Format Naming Convention): 0xCCBBIIII, CC = mono/colour,
// BB = bits per pixel, IIII = id.
constexpr std::array<PixelFormatInfo, 23> kFormats = {{
    {0x01080001u, "Mono8", ColorLayout::kMono, 8, 1},
    {0x01100003u, "Mono10", ColorLayout::kMono, 10, 2},
    {0x01100005u, "Mono12", ColorLayout::kMono, 12, 2},
    {0x01100025u, "Mono14", ColorLayout::kMono, 14, 2},
    {0x01100007u, "Mono16", ColorLayout::kMono, 16, 2},
    {0x01080008u, "BayerGR8", ColorLayout::kBayerGrbg, 8, 1},
    {0x01080009u, "BayerRG8", ColorLayout::kBayerRggb, 8, 1},
    {0x0108000au, "BayerGB8", ColorLayout::kBayerGbrg, 8, 1},
    {0x0108000bu, "BayerBG8", ColorLayout::kBayerBggr, 8, 1},
    {0x0110000cu, "BayerGR10", ColorLayout::kBayerGrbg, 10, 2},
    {0x0110000du, "BayerRG10", ColorLayout::kBayerRggb, 10, 2},
    {0x0110000eu, "BayerGB10", ColorLayout::kBayerGbrg, 10, 2},
    {0x0110000fu, "BayerBG10", ColorLayout::kBayerBggr, 10, 2},
    {0x01100010u, "BayerGR12", ColorLayout::kBayerGrbg, 12, 2},
    {0x01100011u, "BayerRG12", ColorLayout::kBayerRggb, 12, 2},
    {0x01100012u, "BayerGB12", ColorLayout::kBayerGbrg, 12, 2},
    {0x01100013u, "BayerBG12", ColorLayout::kBayerBggr, 12, 2},
    {0x0110002eu, "BayerGR16", ColorLayout::kBayerGrbg, 16, 2},
    {0x0110002fu, "BayerRG16", ColorLayout::kBayerRggb, 16, 2},
    {0x01100030u, "BayerGB16", ColorLayout::kBayerGbrg, 16, 2},
    {0x01100031u, "BayerBG16", ColorLayout::kBayerBggr, 16, 2},
    {0x02180014u, "RGB8", ColorLayout::kRgb, 8, 3},
    {0x02180015u, "BGR8", ColorLayout::kRgb, 8, 3},
}};
constexpr std::uint32_t kBgr8 = 0x02180015u;

}  // namespace

std::optional<PixelFormatInfo> FindPixelFormat(std::uint32_t pfnc) {
  for (const PixelFormatInfo& f : kFormats) {
    if (f.pfnc == pfnc) return f;
  }
  return std::nullopt;
}

std::optional<PixelFormatInfo> FindPixelFormat(const std::string& name) {
  for (const PixelFormatInfo& f : kFormats) {
    if (name == f.name) return f;
  }
  if (name == "RGB8Packed") return FindPixelFormat(0x02180014u);
  if (name == "BGR8Packed") return FindPixelFormat(kBgr8);
  return std::nullopt;
}

CameraImage ImageFromPixels(const void* data, std::size_t size, std::uint32_t pfnc, int width, int height,
                            int row_padding_bytes, const std::string& device_id) {
  const std::optional<PixelFormatInfo> format = FindPixelFormat(pfnc);
  if (!format) {
    char hex[16];
    std::snprintf(hex, sizeof(hex), "0x%08x", pfnc);
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, device_id,
                      std::string("pixel format ") + hex +
                          " is not read by relume; set Mono8/10/12/14/16, Bayer 8/10/12/16 or RGB8 on the camera");
  }
  if (width <= 0 || height <= 0 || row_padding_bytes < 0) {
    throw DeviceError(DeviceErrorKind::kCorruptFrame, device_id,
                      "buffer has an empty or negative region " + std::to_string(width) + "x" + std::to_string(height));
  }
  const std::size_t row_bytes = static_cast<std::size_t>(width) * static_cast<std::size_t>(format->bytes_per_pixel);
  const std::size_t stride = row_bytes + static_cast<std::size_t>(row_padding_bytes);
  const std::size_t needed = stride * static_cast<std::size_t>(height - 1) + row_bytes;
  if (data == nullptr || size < needed) {
    throw DeviceError(DeviceErrorKind::kCorruptFrame, device_id,
                      "frame holds " + std::to_string(size) + " bytes, a " + std::to_string(width) + "x" +
                          std::to_string(height) + " " + format->name + " image needs " + std::to_string(needed));
  }
  const int channels = ChannelCount(format->layout);
  const int depth = format->bits_per_sample > 8 ? CV_16U : CV_8U;
  CameraImage image;
  image.pixels.create(height, width, CV_MAKETYPE(depth, channels));
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  for (int y = 0; y < height; ++y) {
    std::memcpy(image.pixels.ptr(y), bytes + stride * static_cast<std::size_t>(y), row_bytes);
  }
  if (pfnc == kBgr8) {
    for (int y = 0; y < height; ++y) {
      auto* row = image.pixels.ptr<cv::Vec3b>(y);
      for (int x = 0; x < width; ++x) std::swap(row[x][0], row[x][2]);
    }
  }
  image.layout = format->layout;
  image.encoding = SampleEncoding::kSensorLinear;
  image.bits_per_sample = format->bits_per_sample;
  image.black_level = 0;
  image.white_level = (1 << format->bits_per_sample) - 1;
  return image;
}

}  // namespace relume::drivers::aravis
