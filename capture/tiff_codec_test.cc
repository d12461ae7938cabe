#include "capture/tiff_codec.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace relume::capture {
namespace {

cv::Mat Random(int type, std::uint64_t seed) {
  cv::Mat m(37, 53, type);  // odd sizes: a last strip shorter than the others
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(CV_MAT_DEPTH(type) == CV_8U ? 256 : 65536));
  return m;
}

// What OpenCV (libtiff underneath) reads back, in RGB order.
cv::Mat Decode(const std::vector<std::uint8_t>& bytes) {
  cv::Mat m = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2RGB);
  return m;
}

TEST(TiffCodecTest, EveryTypeAndCompressionRoundTripsExactly) {
  for (int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3}) {
    for (auto compression :
         {TiffOptions::Compression::kZstd, TiffOptions::Compression::kDeflate, TiffOptions::Compression::kNone}) {
      TiffOptions options;
      options.compression = compression;
      options.rows_per_strip = 8;
      const cv::Mat pixels = Random(type, static_cast<std::uint64_t>(type) + 1);
      const cv::Mat back = Decode(EncodeTiff(pixels, options));
      ASSERT_EQ(back.type(), type);
      EXPECT_EQ(cv::norm(back, pixels, cv::NORM_INF), 0.0) << "type " << type;
    }
  }
}

TEST(TiffCodecTest, SmoothDepthCompressesAndTheSourceIsUntouched) {
  // The predictor differences rows in place: the caller's image must not change.
  cv::Mat depth_mm(480, 640, CV_16UC1);
  for (int y = 0; y < depth_mm.rows; ++y) {
    for (int x = 0; x < depth_mm.cols; ++x)
      depth_mm.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(1500 + y + x / 4);
  }
  const cv::Mat copy = depth_mm.clone();
  const std::vector<std::uint8_t> bytes = EncodeTiff(depth_mm);
  EXPECT_EQ(cv::norm(depth_mm, copy, cv::NORM_INF), 0.0);
  EXPECT_LT(bytes.size(), depth_mm.total() * 2 / 20);
  EXPECT_EQ(cv::norm(Decode(bytes), depth_mm, cv::NORM_INF), 0.0);
}

TEST(TiffCodecTest, FloatDepthInMetresRoundTripsBitForBitWithItsHoles) {
  cv::Mat depth_m(61, 83, CV_32FC1);
  cv::RNG rng(7);
  for (int y = 0; y < depth_m.rows; ++y) {
    for (int x = 0; x < depth_m.cols; ++x) {
      depth_m.at<float>(y, x) = 1.3f + 0.002f * static_cast<float>(x) + 1e-5f * static_cast<float>(rng.gaussian(1.0));
    }
  }
  depth_m.at<float>(5, 7) = NAN;
  depth_m.at<float>(60, 82) = std::numeric_limits<float>::infinity();
  depth_m.at<float>(0, 0) = 0.0f;
  for (auto compression :
       {TiffOptions::Compression::kZstd, TiffOptions::Compression::kDeflate, TiffOptions::Compression::kNone}) {
    TiffOptions options;
    options.compression = compression;
    const cv::Mat copy = depth_m.clone();
    const cv::Mat back = Decode(EncodeTiff(depth_m, options));
    EXPECT_EQ(std::memcmp(depth_m.data, copy.data, depth_m.total() * sizeof(float)), 0) << "source untouched";
    ASSERT_EQ(back.type(), CV_32FC1);
    ASSERT_TRUE(back.isContinuous());
    EXPECT_EQ(std::memcmp(back.data, depth_m.data, depth_m.total() * sizeof(float)), 0)
        << "every float, NaN and infinity included, comes back bit for bit";
  }
  const cv::Mat rgb(9, 11, CV_32FC3, cv::Scalar(0.25f, 1.5f, 1e6f));
  EXPECT_EQ(cv::norm(Decode(EncodeTiff(rgb)), rgb, cv::NORM_INF), 0.0);
}

TEST(TiffCodecTest, RejectsWhatItCannotStore) {
  EXPECT_THROW(EncodeTiff(cv::Mat(4, 4, CV_64FC1, cv::Scalar(1.0))), InvalidArgumentError);
  EXPECT_THROW(EncodeTiff(cv::Mat(4, 4, CV_8UC4)), InvalidArgumentError);
  EXPECT_THROW(EncodeTiff(cv::Mat()), InvalidArgumentError);
  TiffOptions bad;
  bad.level = 30;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_THROW(EncodeTiff(cv::Mat(4, 4, CV_8UC1), bad), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::capture
