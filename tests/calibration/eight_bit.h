// Test support for the calibration tests on simulator renders: a linear render as the 8-bit
// photograph a camera would give (scaled to its peak, gamma 1/2.2), for board and marker detection.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>

#include "core/image.h"

namespace relume::testing {

inline cv::Mat ToEightBit(const RadianceImage& radiance) {
  double peak = 0.0;
  cv::minMaxLoc(radiance.pixels.reshape(1), nullptr, &peak);
  cv::Mat out(radiance.pixels.size(), CV_8UC3);
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      const cv::Vec3f v = radiance.pixels.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        out.at<cv::Vec3b>(y, x)[c] =
            cv::saturate_cast<std::uint8_t>(255.0 * std::pow(std::max(0.0, v[c] / peak), 1.0 / 2.2));
      }
    }
  }
  return out;
}

}  // namespace relume::testing
