// A minimal DNG writer for simulations and tests: one uncompressed little-endian 16-bit CFA
// (or mono) plane with black and white levels, exposure time and aperture (no ISO: LibRaw reads it from an Exif IFD,
// which this writer has not), the subset of DNG 1.4 that LibRaw needs to decode it like a camera's raw file. Used by
// the simulated DSLR camlib (drivers/gphoto2/simcam) and by the raw-decoding tests; header-only so that the camlib
// needs no relume library.
//
// Conventions: `mosaic` is CV_16UC1, row-major, the sensor's counts (black level included);
// `layout` is the CFA pattern of its top-left 2 x 2 block (kMono: no colour filter array).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/image.h"

namespace relume::testing {

struct DngImage {
  cv::Mat mosaic;  // CV_16UC1
  ColorLayout layout = ColorLayout::kBayerRggb;
  int black_level = 0;
  int white_level = 65535;
  double exposure_time_s = 0.0;  // 0: not written
  double aperture_f = 0.0;
  std::string make = "Relume";
  std::string model = "Simulated";
};

namespace dng_detail {

struct Entry {
  std::uint16_t tag = 0, type = 0;
  std::uint32_t count = 0;
  std::vector<std::uint8_t> data;
};

inline void Put16(std::vector<std::uint8_t>& d, std::uint16_t x) {
  d.push_back(static_cast<std::uint8_t>(x & 0xff));
  d.push_back(static_cast<std::uint8_t>(x >> 8));
}
inline void Put32(std::vector<std::uint8_t>& d, std::uint32_t x) {
  for (int k = 0; k < 4; ++k) d.push_back(static_cast<std::uint8_t>(x >> (8 * k)));
}

class Ifd {
 public:
  void Short(std::uint16_t tag, const std::vector<std::uint16_t>& v) {
    Entry e{tag, 3, static_cast<std::uint32_t>(v.size()), {}};
    for (std::uint16_t x : v) Put16(e.data, x);
    entries_.push_back(std::move(e));
  }
  void Long(std::uint16_t tag, const std::vector<std::uint32_t>& v) {
    Entry e{tag, 4, static_cast<std::uint32_t>(v.size()), {}};
    for (std::uint32_t x : v) Put32(e.data, x);
    entries_.push_back(std::move(e));
  }
  // type 5 = unsigned rational, 10 = signed rational.
  void Rational(std::uint16_t tag, std::uint16_t type, const std::vector<std::pair<std::int64_t, std::int64_t>>& v) {
    Entry e{tag, type, static_cast<std::uint32_t>(v.size()), {}};
    for (const auto& [num, den] : v) {
      Put32(e.data, static_cast<std::uint32_t>(num));
      Put32(e.data, static_cast<std::uint32_t>(den));
    }
    entries_.push_back(std::move(e));
  }
  void Ascii(std::uint16_t tag, const std::string& s) {
    Entry e{tag, 2, static_cast<std::uint32_t>(s.size() + 1), std::vector<std::uint8_t>(s.begin(), s.end())};
    e.data.push_back(0);
    entries_.push_back(std::move(e));
  }
  void Bytes(std::uint16_t tag, const std::vector<std::uint8_t>& v) {
    entries_.push_back({tag, 1, static_cast<std::uint32_t>(v.size()), v});
  }

  // The file: header, this IFD, its out-of-line values, then the strip (tag 273 is patched).
  std::vector<std::uint8_t> Write(const std::vector<std::uint8_t>& strip) {
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) { return a.tag < b.tag; });
    std::vector<std::uint8_t> out = {'I', 'I', 42, 0};
    Put32(out, 8);
    const auto ifd_size = static_cast<std::uint32_t>(2 + 12 * entries_.size() + 4);
    const std::uint32_t values_at = 8 + ifd_size;
    std::vector<std::uint8_t> values;
    std::vector<std::uint8_t> ifd;
    Put16(ifd, static_cast<std::uint16_t>(entries_.size()));
    std::size_t strip_offset_at = 0;
    for (const Entry& e : entries_) {
      Put16(ifd, e.tag);
      Put16(ifd, e.type);
      Put32(ifd, e.count);
      if (e.tag == 273) strip_offset_at = ifd.size();
      if (e.data.size() <= 4) {
        std::vector<std::uint8_t> inline_value = e.data;
        inline_value.resize(4, 0);
        ifd.insert(ifd.end(), inline_value.begin(), inline_value.end());
      } else {
        Put32(ifd, values_at + static_cast<std::uint32_t>(values.size()));
        values.insert(values.end(), e.data.begin(), e.data.end());
        if (values.size() % 2 != 0) values.push_back(0);
      }
    }
    Put32(ifd, 0);  // no next IFD
    const std::uint32_t strip_at = values_at + static_cast<std::uint32_t>(values.size());
    for (int k = 0; k < 4; ++k) ifd[strip_offset_at + k] = static_cast<std::uint8_t>(strip_at >> (8 * k));
    out.insert(out.end(), ifd.begin(), ifd.end());
    out.insert(out.end(), values.begin(), values.end());
    out.insert(out.end(), strip.begin(), strip.end());
    return out;
  }

 private:
  std::vector<Entry> entries_;
};

// An exposure value as a rational with a denominator that keeps 1/8000 s exact.
inline std::pair<std::int64_t, std::int64_t> AsRational(double value) {
  if (value >= 1.0) return {std::llround(value * 1000.0), 1000};
  return {1, std::llround(1.0 / value)};
}

}  // namespace dng_detail

// The DNG file's bytes. `image.mosaic` must be CV_16UC1 and non-empty.
inline std::vector<std::uint8_t> EncodeDng(const DngImage& image) {
  using dng_detail::Ifd;
  const int width = image.mosaic.cols, height = image.mosaic.rows;
  const bool mono = image.layout == ColorLayout::kMono;
  Ifd ifd;
  ifd.Long(254, {0});  // NewSubFileType: the main image
  ifd.Long(256, {static_cast<std::uint32_t>(width)});
  ifd.Long(257, {static_cast<std::uint32_t>(height)});
  ifd.Short(258, {16});                                                // BitsPerSample
  ifd.Short(259, {1});                                                 // no compression
  ifd.Short(262, {static_cast<std::uint16_t>(mono ? 34892 : 32803)});  // LinearRaw for mono, CFA otherwise
  ifd.Ascii(271, image.make);
  ifd.Ascii(272, image.model);
  ifd.Long(273, {0});  // StripOffsets, patched
  ifd.Short(274, {1});
  ifd.Short(277, {1});
  ifd.Long(278, {static_cast<std::uint32_t>(height)});
  ifd.Long(279, {static_cast<std::uint32_t>(width * height * 2)});
  ifd.Short(284, {1});
  if (!mono) {
    // CFA colours: 0 red, 1 green, 2 blue.
    std::vector<std::uint8_t> pattern = {0, 1, 1, 2};
    if (image.layout == ColorLayout::kBayerBggr) pattern = {2, 1, 1, 0};
    if (image.layout == ColorLayout::kBayerGrbg) pattern = {1, 0, 2, 1};
    if (image.layout == ColorLayout::kBayerGbrg) pattern = {1, 2, 0, 1};
    ifd.Short(33421, {2, 2});
    ifd.Bytes(33422, pattern);
  }
  if (image.exposure_time_s > 0.0) ifd.Rational(33434, 5, {dng_detail::AsRational(image.exposure_time_s)});
  if (image.aperture_f > 0.0) ifd.Rational(33437, 5, {{std::llround(image.aperture_f * 100.0), 100}});
  ifd.Bytes(50706, {1, 4, 0, 0});  // DNGVersion
  ifd.Bytes(50707, {1, 1, 0, 0});
  ifd.Ascii(50708, image.make + " " + image.model);
  ifd.Long(50714, {static_cast<std::uint32_t>(image.black_level)});
  ifd.Long(50717, {static_cast<std::uint32_t>(image.white_level)});
  ifd.Rational(50721, 10, {{1, 1}, {0, 1}, {0, 1}, {0, 1}, {1, 1}, {0, 1}, {0, 1}, {0, 1}, {1, 1}});
  ifd.Short(50778, {21});  // CalibrationIlluminant1: D65
  std::vector<std::uint8_t> strip;
  strip.reserve(static_cast<std::size_t>(width) * height * 2);
  for (int y = 0; y < height; ++y) {
    const std::uint16_t* row = image.mosaic.ptr<std::uint16_t>(y);
    for (int x = 0; x < width; ++x) dng_detail::Put16(strip, row[x]);
  }
  return ifd.Write(strip);
}

}  // namespace relume::testing
