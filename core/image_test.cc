#include "core/image.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

namespace relume {
namespace {

TEST(ImageTest, CameraImageValidation) {
  CameraImage image;
  image.pixels = cv::Mat::zeros(4, 6, CV_16UC1);
  image.layout = ColorLayout::kBayerRggb;
  image.encoding = SampleEncoding::kSensorLinear;
  image.bits_per_sample = 12;
  image.black_level = 256;
  image.white_level = 4095;
  std::string why;
  EXPECT_TRUE(image.IsValid(&why)) << why;
  EXPECT_EQ(image.width(), 6);

  image.white_level = 4096;  // does not fit in 12 bits
  EXPECT_FALSE(image.IsValid(&why));
  image.white_level = 4095;
  image.layout = ColorLayout::kRgb;  // a mosaic is one channel
  EXPECT_FALSE(image.IsValid(&why));
  EXPECT_NE(why.find("channel"), std::string::npos);
  image.pixels = cv::Mat::zeros(4, 6, CV_8UC3);
  image.bits_per_sample = 12;  // more bits than 8-bit storage holds
  EXPECT_FALSE(image.IsValid(&why));
  image.pixels = cv::Mat::zeros(4, 6, CV_32FC3);
  EXPECT_FALSE(image.IsValid(&why));
  EXPECT_FALSE(CameraImage{}.IsValid(&why));
}

TEST(ImageTest, RadianceImageValidation) {
  RadianceImage image = MakeRadianceImage(8, 5);
  std::string why;
  EXPECT_TRUE(image.IsValid(&why));
  EXPECT_EQ(image.pixels.type(), CV_32FC3);
  EXPECT_EQ(image.height(), 5);
  image.pixels = cv::Mat::zeros(5, 8, CV_16UC3);
  EXPECT_FALSE(image.IsValid(&why));
  EXPECT_EQ(std::string(ToString(ColorLayout::kBayerGbrg)), "bayer_gbrg");
}

}  // namespace
}  // namespace relume
