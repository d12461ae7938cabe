// Relighting by the ratio of SH irradiances (Ogura & Saito eq. 7):
//   I_dst(x) = I_src(x) * E_dst(n(x)) / E_src(n(x)),
// per channel, with both lights in the camera frame (processing/sh.h). Albedo cancels.
//
// Near-zero denominators: a pixel whose source irradiance in any channel is below
// min_irradiance_fraction times that channel's mean source irradiance over the pixels to
// relight (mask, finite normal and colour) is not divided: it is left out of the valid mask, set to NaN in the relit
// image, and counted in the summary. So are pixels without a finite normal or colour.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

#include "core/image.h"
#include "processing/sh.h"

namespace relume::processing {

struct RelightOptions {
  double min_irradiance_fraction = 0.05;
  bool IsValid(std::string* why) const;
};

struct RelightSummary {
  int requested_pixel_count = 0;  // mask pixels
  int relit_pixel_count = 0;
  int guarded_pixel_count = 0;  // source irradiance too small to divide by
  int invalid_input_count = 0;  // no normal or non-finite colour
  std::string message;
};

struct RelightResult {
  RadianceImage relit;  // RGB; NaN outside `valid`
  cv::Mat valid;        // CV_8UC1, 255 where relit
  RelightSummary summary;
};

// src: RGB radiance; normal_in_camera: CV_32FC3; mask: CV_8UC1 (non-zero = relight this
// pixel; may be empty for all pixels). Throws InvalidArgumentError on mismatched inputs.
RelightResult RelightSh(const RadianceImage& src, const cv::Mat& normal_in_camera, const cv::Mat& mask,
                        const ShRgb& src_light, const ShRgb& dst_light, const RelightOptions& options = {});

// Places `foreground` over `background` where mask is non-zero and the foreground is finite;
// elsewhere the background shows. Sizes must match.
RadianceImage Composite(const RadianceImage& foreground, const cv::Mat& mask, const RadianceImage& background);

}  // namespace relume::processing
