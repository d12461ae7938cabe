// The picture the simulated DSLR (simcam.cc) takes: a deterministic analytic radiance pattern
// and the exposure law that turns it into pixel values. Kept in its own header so that the
// documentation (docs/backends-gphoto2-openni2.md) and the plugin state it once.
//
// Conventions:
//  - Pixel (u, v) has its centre at x = (u + 0.5) / W, y = (v + 0.5) / H (core/image.h).
//  - Relative radiance per channel c (R, G, B):
//        r_c(x, y) = a_c * 2^(-6 x) * (0.75 + 0.25 cos(6 pi y)),  a = (1.0, 0.8, 0.6)
//    a horizontal ramp over 6 stops with a vertical ripple, maximal (r_R = 1) at the left edge.
//  - Exposure law (a fraction of full scale): s = r * (t / (1/60 s)) * (ISO / 100) * (8 / N)^2
//    * 2^EV, with t the shutter time, N the f-number, EV the exposure compensation. So
//    1/60 s, f/8, ISO 100, EV 0 brings the brightest pixel exactly to full scale.
//  - 16-bit TIFF: linear counts round(65535 * min(s, 1)), black level 0.
//  - JPEG: 8-bit, round(255 * min(s, 1)^(1 / 2.2)) (a pure power-law "camera response").
//  - RAW: a DNG (core/testing/dng_writer.h) holding the RGGB mosaic (channel of pixel (u, v):
//    R at even u and v, B at odd u and v, G elsewhere), 14-bit counts
//    kRawBlack + round((kRawWhite - kRawBlack) * min(s, 1)), with exposure time and f-number.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace relume::drivers::simcam {

inline constexpr double kChannelGain[3] = {1.0, 0.8, 0.6};
inline constexpr int kRawBlack = 512;
inline constexpr int kRawWhite = 16383;

// Relative radiance of channel c at the centre of pixel (u, v) of a width x height frame.
inline double SceneRadiance(int u, int v, int c, int width, int height) {
  const double x = (u + 0.5) / width;
  const double y = (v + 0.5) / height;
  return kChannelGain[c] * std::exp2(-6.0 * x) * (0.75 + 0.25 * std::cos(6.0 * M_PI * y));
}

// The factor s / r of the exposure law above.
inline double ExposureScale(double exposure_time_s, double aperture_f, double iso, double ev_compensation) {
  return exposure_time_s * 60.0 * (iso / 100.0) * (8.0 / aperture_f) * (8.0 / aperture_f) * std::exp2(ev_compensation);
}

// The RAW count of a fraction s in [0, 1] of full scale.
inline std::uint16_t RawCount(double s) {
  return static_cast<std::uint16_t>(kRawBlack + std::lround((kRawWhite - kRawBlack) * std::clamp(s, 0.0, 1.0)));
}

}  // namespace relume::drivers::simcam
