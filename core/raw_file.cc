#include "core/raw_file.h"

#include <libraw/libraw.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <memory>
#include <vector>

#include "core/error.h"
#include "core/input_file.h"

namespace relume {
namespace {

ColorLayout LayoutFromPattern(int c00, int c01, int c10, int c11) {
  // LibRaw colours: 0 red, 1 green, 2 blue, 3 second green.
  auto g = [](int c) { return c == 1 || c == 3; };
  if (c00 == 0 && g(c01) && g(c10) && c11 == 2) return ColorLayout::kBayerRggb;
  if (c00 == 2 && g(c01) && g(c10) && c11 == 0) return ColorLayout::kBayerBggr;
  if (g(c00) && c01 == 0 && c10 == 2 && g(c11)) return ColorLayout::kBayerGrbg;
  if (g(c00) && c01 == 2 && c10 == 0 && g(c11)) return ColorLayout::kBayerGbrg;
  return ColorLayout::kMono;
}

}  // namespace

bool IsRawFormat(std::string_view format) {
  static constexpr std::string_view kRaw[] = {"nef", "nrw", "cr2", "cr3", "crw", "arw", "srf", "sr2", "dng",
                                              "orf", "rw2", "raf", "pef", "srw", "x3f", "3fr", "iiq", "raw"};
  return std::find(std::begin(kRaw), std::end(kRaw), format) != std::end(kRaw);
}

RawFile DecodeRawFile(std::span<const std::uint8_t> bytes, const std::string& name) {
  auto raw = std::make_unique<LibRaw>();
  // LibRaw's buffer interface is not const-correct; it only reads the buffer.
  std::vector<std::uint8_t> copy(bytes.begin(), bytes.end());
  int rc = raw->open_buffer(copy.data(), copy.size());
  if (rc != LIBRAW_SUCCESS) throw IoError(name, std::string("LibRaw cannot open it: ") + libraw_strerror(rc));
  rc = raw->unpack();
  if (rc != LIBRAW_SUCCESS) throw IoError(name, std::string("LibRaw cannot decode it: ") + libraw_strerror(rc));
  const auto& sizes = raw->imgdata.sizes;
  const auto& idata = raw->imgdata.idata;
  if (raw->imgdata.rawdata.raw_image == nullptr) {
    throw InvalidArgumentError(name +
                               ": not a single-plane raw (linear RGB or Foveon); relume reads Bayer and mono raw");
  }
  if (idata.filters == 9) throw InvalidArgumentError(name + ": X-Trans sensors are not supported");
  RawFile out;
  out.make = idata.make;
  out.model = idata.model;
  out.exposure_time_s = raw->imgdata.other.shutter;
  out.aperture_f = raw->imgdata.other.aperture;
  out.iso = raw->imgdata.other.iso_speed;
  const int width = sizes.width, height = sizes.height;
  CameraImage& image = out.image;
  image.pixels = cv::Mat(height, width, CV_16UC1);
  const std::size_t pitch = sizes.raw_pitch / 2;
  const unsigned short* src = raw->imgdata.rawdata.raw_image;
  for (int y = 0; y < height; ++y) {
    const unsigned short* row = src + (y + sizes.top_margin) * pitch + sizes.left_margin;
    std::copy(row, row + width, image.pixels.ptr<std::uint16_t>(y));
  }
  image.layout = idata.filters == 0
                     ? ColorLayout::kMono
                     : LayoutFromPattern(raw->COLOR(0, 0), raw->COLOR(0, 1), raw->COLOR(1, 0), raw->COLOR(1, 1));
  image.encoding = SampleEncoding::kSensorLinear;
  const auto& color = raw->imgdata.color;
  const unsigned extra_black = std::min({color.cblack[0], color.cblack[1], color.cblack[2], color.cblack[3]});
  image.black_level = static_cast<int>(color.black + extra_black);
  image.white_level = static_cast<int>(std::min(color.maximum, 65535u));
  int bits = 8;
  while (bits < 16 && (1 << bits) - 1 < image.white_level) ++bits;
  image.bits_per_sample = bits;
  std::string why;
  if (!image.IsValid(&why)) throw IoError(name, "LibRaw's levels are inconsistent: " + why);
  return out;
}

RawFile LoadRawFile(const std::string& path) {
  std::ifstream in = OpenInputFile(path, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError(path, "read error");
  return DecodeRawFile(bytes, path);
}

}  // namespace relume
