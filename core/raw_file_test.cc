#include "core/raw_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/testing/dng_writer.h"

namespace relume {
namespace {

// Pixel value of the synthetic mosaic: red sites 3000, green 2000, blue 1000, plus x.
std::uint16_t MosaicValue(int x, int y) {
  const bool red = (y % 2 == 0) && (x % 2 == 0);
  const bool blue = (y % 2 == 1) && (x % 2 == 1);
  return static_cast<std::uint16_t>((red ? 3000 : blue ? 1000 : 2000) + x);
}

testing::DngImage TestImage(int width, int height) {
  testing::DngImage image;
  image.mosaic = cv::Mat(height, width, CV_16UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) image.mosaic.at<std::uint16_t>(y, x) = MosaicValue(x, y);
  }
  image.black_level = 256;
  image.white_level = 4095;
  image.exposure_time_s = 1.0 / 125.0;
  image.aperture_f = 5.6;
  image.model = "Synthetic";
  return image;
}

TEST(RawFileTest, DecodesAGeneratedDngFromMemory) {
  const RawFile raw = DecodeRawFile(testing::EncodeDng(TestImage(64, 48)), "test.dng");
  const CameraImage& image = raw.image;
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  EXPECT_EQ(image.layout, ColorLayout::kBayerRggb);
  EXPECT_EQ(image.encoding, SampleEncoding::kSensorLinear);
  EXPECT_EQ(image.black_level, 256);
  EXPECT_EQ(image.white_level, 4095);
  EXPECT_EQ(image.bits_per_sample, 12);
  EXPECT_NEAR(raw.exposure_time_s, 1.0 / 125.0, 1e-9);
  EXPECT_NEAR(raw.aperture_f, 5.6, 1e-6);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) ASSERT_EQ(image.pixels.at<std::uint16_t>(y, x), MosaicValue(x, y)) << x << "," << y;
  }
}

// LibRaw (like dcraw) takes no image smaller than 22 x 22 pixels for a raw file.
TEST(RawFileTest, KeepsEachBayerLayout) {
  for (ColorLayout layout : {ColorLayout::kBayerRggb, ColorLayout::kBayerBggr, ColorLayout::kBayerGrbg,
                             ColorLayout::kBayerGbrg, ColorLayout::kMono}) {
    testing::DngImage image = TestImage(32, 24);
    image.layout = layout;
    EXPECT_EQ(DecodeRawFile(testing::EncodeDng(image), "layout.dng").image.layout, layout) << ToString(layout);
  }
}

TEST(RawFileTest, LoadsFromDisk) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("relume_raw_test_" + std::to_string(::getpid()) + ".dng")).string();
  const std::vector<std::uint8_t> bytes = testing::EncodeDng(TestImage(32, 24));
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  const RawFile raw = LoadRawFile(path);
  std::filesystem::remove(path);
  EXPECT_EQ(raw.image.pixels.at<std::uint16_t>(3, 5), MosaicValue(5, 3));
  EXPECT_EQ(raw.model, "Synthetic");
}

TEST(RawFileTest, MissingTruncatedOrNonRawFilesAreIoErrors) {
  EXPECT_THROW(LoadRawFile("/nonexistent/relume.dng"), IoError);
  const std::vector<std::uint8_t> text = {'n', 'o', 't', ' ', 'r', 'a', 'w'};
  EXPECT_THROW(DecodeRawFile(text, "text.nef"), IoError);
  EXPECT_THROW(DecodeRawFile({}, "empty.nef"), IoError);
  std::vector<std::uint8_t> truncated = testing::EncodeDng(TestImage(64, 48));
  truncated.resize(200);  // the header survives, the strip does not
  try {
    DecodeRawFile(truncated, "cut.dng");
    ADD_FAILURE() << "a truncated DNG decoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.dng"), std::string::npos) << e.what();
  }
}

TEST(RawFileTest, NamesRawFormats) {
  for (const char* raw : {"nef", "cr2", "cr3", "arw", "dng", "raf", "orf", "rw2"}) EXPECT_TRUE(IsRawFormat(raw)) << raw;
  for (const char* other : {"jpeg", "jpg", "tiff", "png", "", "NEF"}) EXPECT_FALSE(IsRawFormat(other)) << other;
}

}  // namespace
}  // namespace relume
