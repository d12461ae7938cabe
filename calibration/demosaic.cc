#include "calibration/demosaic.h"

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace relume::calibration {

CameraImage DemosaicBilinear(const CameraImage& bayer) {
  std::string why;
  if (!bayer.IsValid(&why)) throw InvalidArgumentError("raw frame: " + why);
  int code = -1;
  // OpenCV names Bayer patterns by the second row's first two pixels.
  switch (bayer.layout) {
    case ColorLayout::kBayerRggb: code = cv::COLOR_BayerBG2RGB; break;
    case ColorLayout::kBayerBggr: code = cv::COLOR_BayerRG2RGB; break;
    case ColorLayout::kBayerGrbg: code = cv::COLOR_BayerGB2RGB; break;
    case ColorLayout::kBayerGbrg: code = cv::COLOR_BayerGR2RGB; break;
    default: throw InvalidArgumentError("demosaicing needs a Bayer layout, got " + std::string(ToString(bayer.layout)));
  }
  CameraImage rgb = bayer;
  cv::cvtColor(bayer.pixels, rgb.pixels, code);
  rgb.layout = ColorLayout::kRgb;
  return rgb;
}

}  // namespace relume::calibration
