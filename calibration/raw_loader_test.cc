#include "calibration/raw_loader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.h"

namespace relume::calibration {
namespace {

// Writes a minimal uncompressed little-endian DNG: one 16-bit RGGB CFA plane with black and
// white levels and an exposure time, enough for LibRaw to decode.
class DngWriter {
 public:
  void Add(std::uint16_t tag, std::uint16_t type, std::uint32_t count, std::vector<std::uint8_t> data) {
    entries_.push_back({tag, type, count, std::move(data)});
  }
  void Short(std::uint16_t tag, std::vector<std::uint16_t> v) {
    std::vector<std::uint8_t> d;
    for (auto x : v) d.insert(d.end(), {static_cast<std::uint8_t>(x & 0xff), static_cast<std::uint8_t>(x >> 8)});
    Add(tag, 3, static_cast<std::uint32_t>(v.size()), d);
  }
  void Long(std::uint16_t tag, std::vector<std::uint32_t> v) {
    std::vector<std::uint8_t> d;
    for (auto x : v) Append32(d, x);
    Add(tag, 4, static_cast<std::uint32_t>(v.size()), d);
  }
  void Rational(std::uint16_t tag, std::uint16_t type, std::vector<std::pair<std::int32_t, std::int32_t>> v) {
    std::vector<std::uint8_t> d;
    for (auto [n, den] : v) {
      Append32(d, static_cast<std::uint32_t>(n));
      Append32(d, static_cast<std::uint32_t>(den));
    }
    Add(tag, type, static_cast<std::uint32_t>(v.size()), d);
  }
  void Ascii(std::uint16_t tag, const std::string& s) {
    std::vector<std::uint8_t> d(s.begin(), s.end());
    d.push_back(0);
    Add(tag, 2, static_cast<std::uint32_t>(d.size()), d);
  }
  void Bytes(std::uint16_t tag, std::vector<std::uint8_t> v) { Add(tag, 1, static_cast<std::uint32_t>(v.size()), v); }

  void Write(const std::string& path, const std::vector<std::uint16_t>& pixels) {
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) { return a.tag < b.tag; });
    std::vector<std::uint8_t> out = {'I', 'I', 42, 0};
    Append32(out, 8);
    const std::uint32_t ifd_size = 2 + 12 * static_cast<std::uint32_t>(entries_.size()) + 4;
    std::uint32_t extra = 8 + ifd_size;
    std::vector<std::uint8_t> extra_data;
    std::vector<std::uint8_t> ifd;
    Append16(ifd, static_cast<std::uint16_t>(entries_.size()));
    // The strip goes after the IFD's out-of-line values; its offset is patched below.
    std::size_t strip_offset_pos = 0;
    for (const Entry& e : entries_) {
      Append16(ifd, e.tag);
      Append16(ifd, e.type);
      Append32(ifd, e.count);
      if (e.tag == 273) strip_offset_pos = ifd.size();
      if (e.data.size() <= 4) {
        std::vector<std::uint8_t> d = e.data;
        d.resize(4, 0);
        ifd.insert(ifd.end(), d.begin(), d.end());
      } else {
        Append32(ifd, extra + static_cast<std::uint32_t>(extra_data.size()));
        extra_data.insert(extra_data.end(), e.data.begin(), e.data.end());
        if (extra_data.size() % 2) extra_data.push_back(0);
      }
    }
    Append32(ifd, 0);
    const std::uint32_t strip = extra + static_cast<std::uint32_t>(extra_data.size());
    for (int k = 0; k < 4; ++k) ifd[strip_offset_pos + k] = static_cast<std::uint8_t>(strip >> (8 * k));
    out.insert(out.end(), ifd.begin(), ifd.end());
    out.insert(out.end(), extra_data.begin(), extra_data.end());
    for (auto p : pixels) Append16(out, p);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(out.data()), out.size());
  }

 private:
  struct Entry {
    std::uint16_t tag, type;
    std::uint32_t count;
    std::vector<std::uint8_t> data;
  };
  static void Append16(std::vector<std::uint8_t>& d, std::uint16_t x) {
    d.insert(d.end(), {static_cast<std::uint8_t>(x & 0xff), static_cast<std::uint8_t>(x >> 8)});
  }
  static void Append32(std::vector<std::uint8_t>& d, std::uint32_t x) {
    for (int k = 0; k < 4; ++k) d.push_back(static_cast<std::uint8_t>(x >> (8 * k)));
  }
  std::vector<Entry> entries_;
};

// Pixel value of the synthetic mosaic: red sites 3000, green 2000, blue 1000, plus x.
std::uint16_t MosaicValue(int x, int y) {
  const bool red = (y % 2 == 0) && (x % 2 == 0);
  const bool blue = (y % 2 == 1) && (x % 2 == 1);
  return static_cast<std::uint16_t>((red ? 3000 : blue ? 1000 : 2000) + x);
}

std::string WriteTestDng(int width, int height) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("relume_raw_test_" + std::to_string(::getpid()) + ".dng")).string();
  DngWriter w;
  w.Long(254, {0});
  w.Long(256, {static_cast<std::uint32_t>(width)});
  w.Long(257, {static_cast<std::uint32_t>(height)});
  w.Short(258, {16});
  w.Short(259, {1});
  w.Short(262, {32803});
  w.Ascii(271, "Relume");
  w.Ascii(272, "Synthetic");
  w.Long(273, {0});
  w.Short(274, {1});
  w.Short(277, {1});
  w.Long(278, {static_cast<std::uint32_t>(height)});
  w.Long(279, {static_cast<std::uint32_t>(width * height * 2)});
  w.Short(284, {1});
  w.Short(33421, {2, 2});
  w.Bytes(33422, {0, 1, 1, 2});
  w.Rational(33434, 5, {{1, 125}});
  w.Bytes(50706, {1, 4, 0, 0});
  w.Bytes(50707, {1, 1, 0, 0});
  w.Ascii(50708, "Relume Synthetic");
  w.Long(50714, {256});
  w.Long(50717, {4095});
  w.Rational(50721, 10, {{1, 1}, {0, 1}, {0, 1}, {0, 1}, {1, 1}, {0, 1}, {0, 1}, {0, 1}, {1, 1}});
  w.Short(50778, {21});
  std::vector<std::uint16_t> pixels;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) pixels.push_back(MosaicValue(x, y));
  }
  w.Write(path, pixels);
  return path;
}

TEST(RawLoaderTest, ReadsAGeneratedDng) {
  const std::string path = WriteTestDng(64, 48);
  const RawFile raw = LoadRawFile(path);
  std::filesystem::remove(path);
  const CameraImage& image = raw.image;
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  EXPECT_EQ(image.layout, ColorLayout::kBayerRggb);
  EXPECT_EQ(image.encoding, SampleEncoding::kSensorLinear);
  EXPECT_EQ(image.black_level, 256);
  EXPECT_EQ(image.white_level, 4095);
  EXPECT_EQ(image.bits_per_sample, 12);
  EXPECT_NEAR(raw.exposure_time_s, 1.0 / 125.0, 1e-9);
  for (int y : {0, 1, 10, 47}) {
    for (int x : {0, 1, 33, 63}) EXPECT_EQ(image.pixels.at<std::uint16_t>(y, x), MosaicValue(x, y)) << x << "," << y;
  }
}

TEST(RawLoaderTest, DemosaicKeepsChannelsApart) {
  CameraImage bayer;
  bayer.pixels = cv::Mat(8, 8, CV_16UC1);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x)
      bayer.pixels.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(((y % 2 == 0 && x % 2 == 0)   ? 3000
                                                                         : (y % 2 == 1 && x % 2 == 1) ? 1000
                                                                                                      : 2000));
  }
  bayer.layout = ColorLayout::kBayerRggb;
  bayer.encoding = SampleEncoding::kSensorLinear;
  bayer.bits_per_sample = 12;
  bayer.white_level = 4095;
  const CameraImage rgb = DemosaicBilinear(bayer);
  ASSERT_EQ(rgb.layout, ColorLayout::kRgb);
  const cv::Vec3w p = rgb.pixels.at<cv::Vec3w>(4, 4);
  EXPECT_EQ(p[0], 3000);
  EXPECT_EQ(p[1], 2000);
  EXPECT_EQ(p[2], 1000);
}

TEST(RawLoaderTest, MissingOrNonRawFileIsAnIoError) {
  EXPECT_THROW(LoadRawFile("/nonexistent/relume.dng"), IoError);
  const std::string path = (std::filesystem::temp_directory_path() / "relume_not_raw.txt").string();
  std::ofstream(path) << "not a raw file";
  EXPECT_THROW(LoadRawFile(path), IoError);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace relume::calibration
