#include "calibration/demosaic.h"

#include <gtest/gtest.h>

#include <cstdint>

#include "core/error.h"

namespace relume::calibration {
namespace {

TEST(DemosaicTest, DemosaicKeepsChannelsApart) {
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

}  // namespace
}  // namespace relume::calibration
