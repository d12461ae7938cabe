// The simulated camera's radiometry: scene radiance -> photo-electrons -> raw sensor counts and
// camera-encoded 8-bit pixels, and the exact inverse for tests. Pure functions of an Options
// struct; the pinhole geometry (pose, intrinsics) comes from the caller (core/pinhole.h).
//
// Conventions (stated once, here):
//  - Input radiance is linear RGB in W m^-2 sr^-1 (sim/truth.h). Each channel is one band with
//    the same photo-electron yield (no spectral model, no colour filter cross-talk).
//  - Sensor-plane irradiance, thin lens focused at infinity, lossless optics:
//      E = L * pi / (4 N^2) * V(u, v),   N = f-number, V = vignetting factor (1 on the axis).
//  - Photo-electrons: e = E * t * electrons_per_j_per_sqm (t = exposure time in s). The pixel
//    saturates at full_well_e, before any gain.
//  - Gain: g = (iso / base_iso) * 10^(gain_db / 20). The camera's "white" is reached when
//    e * g = full_well_e; at unit gain that is the full well.
//  - Raw counts: black_level + round(e * g * counts_per_electron), clipped to white_level =
//    2^raw_bits - 1; counts_per_electron maps full_well_e to white_level - black_level.
//  - Encoded: x = clamp(e * g / full_well_e, 0, 1), pixel = round(255 * response(x)).
//  - Noise is a separate step (AddSensorNoise): shot noise (Poisson, Gaussian approximation with
//    variance e) and read noise (Gaussian, read_noise_e), from a fixed seed. ExpectedElectrons
//    is the noise-free ground truth, as COLMAP's synthetic data keeps truth and noise apart.
//  - Bayer RGGB mosaic: pixel (x, y) keeps R where x and y are even, B where both are odd, G
//    elsewhere.
//  - Pixel centres at (x + 0.5, y + 0.5) (core/image.h); vignetting is evaluated there.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"

namespace relume::sim {

// A monotonic camera response: linear signal x in [0, 1] -> encoded value y in [0, 1].
struct ResponseCurve {
  enum class Shape {
    kLinear,  // y = x
    kGamma,   // y = x^(1 / gamma)
    kFilmic,  // S-shaped: p = x^(1 / gamma), y = p^c / (p^c + (1 - p)^c), c = contrast
    kTable,   // piecewise linear through table[i] at x = i / (n - 1)
  };
  Shape shape = Shape::kGamma;
  double gamma = 2.2;
  double contrast = 1.6;      // kFilmic: slope of the S in its middle (p = 0.5); 1 = no S
  std::vector<double> table;  // kTable: strictly increasing values within [0, 1], at least 2

  static ResponseCurve Linear();
  static ResponseCurve Gamma(double gamma);
  static ResponseCurve Filmic(double gamma, double contrast);
  static ResponseCurve FromTable(std::vector<double> values);

  double Encode(double x) const;  // x outside [0, 1] is clamped
  double Decode(double y) const;  // exact inverse of Encode on [0, 1]; y is clamped
  bool IsValid(std::string* why) const;
};
const char* ToString(ResponseCurve::Shape shape);

struct Vignetting {
  enum class Model {
    kNone,
    kCos4,        // V = cos^4(angle between the pixel's ray and the optical axis)
    kPolynomial,  // V = 1 + k1 r^2 + k2 r^4 + k3 r^6, r = distance to (cx, cy) / half-diagonal
  };
  Model model = Model::kNone;
  double k1 = 0.0, k2 = 0.0, k3 = 0.0;
  // The factor at a continuous image point; in (0, 1] for valid options.
  double Factor(const PinholeIntrinsics& intrinsics, double x, double y) const;
  bool IsValid(std::string* why) const;
};
const char* ToString(Vignetting::Model model);

struct CameraModelOptions {
  double full_well_e = 40000.0;
  // Photo-electrons per J m^-2 of sensor-plane exposure, per channel. The default (a ~4.3 um
  // pixel, ~25 % quantum efficiency behind its colour filter) puts a white Lambertian surface
  // in full sun (~100 W m^-2 sr^-1 per channel) near the full well at f/16, 1/100 s, ISO 100.
  double electrons_per_j_per_sqm = 1.3e7;
  double read_noise_e = 3.0;
  bool shot_noise = true;
  std::uint64_t noise_seed = 1;
  int raw_bits = 14;                           // 8, 10, 12, 14 or 16
  double black_level_fraction = 1.0 / 32;      // black level as a fraction of 2^raw_bits - 1
  ColorLayout raw_layout = ColorLayout::kRgb;  // kRgb or kBayerRggb
  double base_iso = 100.0;
  ResponseCurve response;
  Vignetting vignetting;

  bool IsValid(std::string* why) const;
  int black_level() const;
  int white_level() const { return (1 << raw_bits) - 1; }
  double counts_per_electron() const { return (white_level() - black_level()) / full_well_e; }
};

// The exposure of one frame.
struct ExposureParams {
  double exposure_time_s = 1.0 / 100;
  double aperture_f = 8.0;
  double iso = 100.0;
  double gain_db = 0.0;
  bool IsValid(std::string* why) const;
  double Gain(const CameraModelOptions& options) const;
};

// Electrons per unit radiance (W m^-2 sr^-1) at continuous image point (x, y).
double ElectronsPerRadiance(const PinholeIntrinsics& intrinsics, double x, double y, const ExposureParams& exposure,
                            const CameraModelOptions& options);

// Noise-free photo-electrons (CV_32FC3), not yet clipped at the full well, for an RGB radiance
// image of the intrinsics' size. Throws InvalidArgumentError on invalid options or sizes.
cv::Mat ExpectedElectrons(const RadianceImage& radiance, const PinholeIntrinsics& intrinsics,
                          const ExposureParams& exposure, const CameraModelOptions& options);

// Shot and read noise added to expected electrons (any float type); deterministic in `seed`.
cv::Mat AddSensorNoise(const cv::Mat& electrons, const CameraModelOptions& options, std::uint64_t seed);

// Raw sensor counts (CameraImage kSensorLinear): CV_8U for 8 bits, else CV_16U; RGB or RGGB.
CameraImage RawFromElectrons(const cv::Mat& electrons, const ExposureParams& exposure,
                             const CameraModelOptions& options);
// Camera-encoded 8-bit RGB (CameraImage kCameraResponse).
CameraImage EncodedFromElectrons(const cv::Mat& electrons, const ExposureParams& exposure,
                                 const CameraModelOptions& options);

// Exact inverses at one sample. They return NaN for a saturated sample (raw count at
// white_level, encoded 255): its radiance is only known to be at least the saturation value.
double RadianceFromRawCount(int count, const PinholeIntrinsics& intrinsics, double x, double y,
                            const ExposureParams& exposure, const CameraModelOptions& options);
double RadianceFromEncodedValue(int value, const PinholeIntrinsics& intrinsics, double x, double y,
                                const ExposureParams& exposure, const CameraModelOptions& options);
// The radiance at which a sample saturates at (x, y).
double SaturationRadiance(const PinholeIntrinsics& intrinsics, double x, double y, const ExposureParams& exposure,
                          const CameraModelOptions& options);

// Whole-image inverse of an RGB raw or encoded image (kWattsPerSqmPerSr); NaN marks saturated
// samples (masked, core/image.h). Bayer mosaics need per-sample RadianceFromRawCount.
RadianceImage RadianceFromCameraImage(const CameraImage& image, const PinholeIntrinsics& intrinsics,
                                      const ExposureParams& exposure, const CameraModelOptions& options);

}  // namespace relume::sim
