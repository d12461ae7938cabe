#include "sim/devices/camera_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "core/error.h"
#include "sim/devices/random.h"

namespace relume::sim {
namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

double Clamp01(double v) {
  return std::clamp(v, 0.0, 1.0);
}

}  // namespace

ResponseCurve ResponseCurve::Linear() {
  ResponseCurve curve;
  curve.shape = Shape::kLinear;
  return curve;
}
ResponseCurve ResponseCurve::Gamma(double gamma) {
  ResponseCurve curve;
  curve.shape = Shape::kGamma;
  curve.gamma = gamma;
  return curve;
}
ResponseCurve ResponseCurve::Filmic(double gamma, double contrast) {
  ResponseCurve curve;
  curve.shape = Shape::kFilmic;
  curve.gamma = gamma;
  curve.contrast = contrast;
  return curve;
}
ResponseCurve ResponseCurve::FromTable(std::vector<double> values) {
  ResponseCurve curve;
  curve.shape = Shape::kTable;
  curve.table = std::move(values);
  return curve;
}

double ResponseCurve::Encode(double x) const {
  x = Clamp01(x);
  switch (shape) {
    case Shape::kLinear: return x;
    case Shape::kGamma: return std::pow(x, 1.0 / gamma);
    case Shape::kFilmic: {
      const double p = std::pow(x, 1.0 / gamma);
      if (p <= 0.0 || p >= 1.0) return p;
      const double a = std::pow(p, contrast);
      return a / (a + std::pow(1.0 - p, contrast));
    }
    case Shape::kTable: {
      const double position = x * static_cast<double>(table.size() - 1);
      const std::size_t i = std::min(static_cast<std::size_t>(position), table.size() - 2);
      const double t = position - static_cast<double>(i);
      return table[i] + t * (table[i + 1] - table[i]);
    }
  }
  return x;
}

double ResponseCurve::Decode(double y) const {
  y = Clamp01(y);
  switch (shape) {
    case Shape::kLinear: return y;
    case Shape::kGamma: return std::pow(y, gamma);
    case Shape::kFilmic: {
      if (y <= 0.0 || y >= 1.0) return y;
      const double ratio = std::pow(y / (1.0 - y), 1.0 / contrast);  // p / (1 - p)
      return std::pow(ratio / (1.0 + ratio), gamma);
    }
    case Shape::kTable: {
      if (y <= table.front()) return 0.0;
      if (y >= table.back()) return 1.0;
      const auto upper = std::upper_bound(table.begin(), table.end(), y);
      const std::size_t i = static_cast<std::size_t>(upper - table.begin()) - 1;
      const double t = (y - table[i]) / (table[i + 1] - table[i]);
      return (static_cast<double>(i) + t) / static_cast<double>(table.size() - 1);
    }
  }
  return y;
}

bool ResponseCurve::IsValid(std::string* why) const {
  switch (shape) {
    case Shape::kLinear: return true;
    case Shape::kFilmic:
      if (!(std::isfinite(contrast) && contrast >= 1.0 && contrast <= 10.0))
        return Fail(why, "filmic contrast must be within [1, 10]");
      [[fallthrough]];
    case Shape::kGamma:
      if (!(std::isfinite(gamma) && gamma >= 0.2 && gamma <= 5.0)) return Fail(why, "gamma must be within [0.2, 5]");
      return true;
    case Shape::kTable:
      if (table.size() < 2) return Fail(why, "a response table needs at least 2 values");
      for (std::size_t i = 0; i < table.size(); ++i) {
        if (!(std::isfinite(table[i]) && table[i] >= 0.0 && table[i] <= 1.0))
          return Fail(why, "response table values must be within [0, 1]");
        if (i > 0 && !(table[i] > table[i - 1]))
          return Fail(why, "response table must be strictly increasing (at index " + std::to_string(i) + ")");
      }
      return true;
  }
  return Fail(why, "unknown response shape");
}

const char* ToString(ResponseCurve::Shape shape) {
  switch (shape) {
    case ResponseCurve::Shape::kLinear: return "linear";
    case ResponseCurve::Shape::kGamma: return "gamma";
    case ResponseCurve::Shape::kFilmic: return "filmic";
    case ResponseCurve::Shape::kTable: return "table";
  }
  return "unknown";
}

double Vignetting::Factor(const PinholeIntrinsics& intrinsics, double x, double y) const {
  switch (model) {
    case Model::kNone: return 1.0;
    case Model::kCos4: {
      const double a = (x - intrinsics.cx) / intrinsics.fx;
      const double b = (y - intrinsics.cy) / intrinsics.fy;
      const double cos2 = 1.0 / (1.0 + a * a + b * b);
      return cos2 * cos2;
    }
    case Model::kPolynomial: {
      const double half_diagonal = 0.5 * std::hypot(intrinsics.width, intrinsics.height);
      const double r2 =
          (std::pow(x - intrinsics.cx, 2) + std::pow(y - intrinsics.cy, 2)) / (half_diagonal * half_diagonal);
      return 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    }
  }
  return 1.0;
}

bool Vignetting::IsValid(std::string* why) const {
  if (model != Model::kPolynomial) return true;
  if (!(std::isfinite(k1) && std::isfinite(k2) && std::isfinite(k3)))
    return Fail(why, "vignetting k1..k3 must be finite");
  // The factor must stay within (0, 1] out to the corners (r up to 1.5 covers off-centre
  // principal points): check densely, since a polynomial can dip and come back.
  for (int i = 0; i <= 150; ++i) {
    const double r2 = std::pow(i / 100.0, 2);
    const double v = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    if (!(v > 0.0 && v <= 1.0 + 1e-12))
      return Fail(why, "polynomial vignetting must stay within (0, 1] for r in [0, 1.5] (falls to " +
                           std::to_string(v) + " at r = " + std::to_string(i / 100.0) + ")");
  }
  return true;
}

const char* ToString(Vignetting::Model model) {
  switch (model) {
    case Vignetting::Model::kNone: return "none";
    case Vignetting::Model::kCos4: return "cos4";
    case Vignetting::Model::kPolynomial: return "polynomial";
  }
  return "unknown";
}

bool CameraModelOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(full_well_e) && full_well_e >= 100.0 && full_well_e <= 1e7))
    return Fail(why, "full_well_e must be within [100, 1e7] electrons");
  if (!(std::isfinite(electrons_per_j_per_sqm) && electrons_per_j_per_sqm > 0.0))
    return Fail(why, "electrons_per_j_per_sqm must be positive");
  if (!(std::isfinite(read_noise_e) && read_noise_e >= 0.0 && read_noise_e < full_well_e))
    return Fail(why, "read_noise_e must be within [0, full_well_e)");
  if (raw_bits != 8 && raw_bits != 10 && raw_bits != 12 && raw_bits != 14 && raw_bits != 16)
    return Fail(why, "raw_bits must be 8, 10, 12, 14 or 16 (got " + std::to_string(raw_bits) + ")");
  if (!(black_level_fraction >= 0.0 && black_level_fraction <= 0.25))
    return Fail(why, "black_level_fraction must be within [0, 0.25]");
  if (raw_layout != ColorLayout::kRgb && raw_layout != ColorLayout::kBayerRggb)
    return Fail(why, "raw_layout must be rgb or bayer_rggb");
  if (!(std::isfinite(base_iso) && base_iso > 0.0)) return Fail(why, "base_iso must be positive");
  std::string reason;
  if (!response.IsValid(&reason)) return Fail(why, "response: " + reason);
  if (!vignetting.IsValid(&reason)) return Fail(why, "vignetting: " + reason);
  return true;
}

int CameraModelOptions::black_level() const {
  return static_cast<int>(std::lround(black_level_fraction * white_level()));
}

bool ExposureParams::IsValid(std::string* why) const {
  if (!(std::isfinite(exposure_time_s) && exposure_time_s > 0.0 && exposure_time_s <= 3600.0))
    return Fail(why, "exposure_time_s must be within (0, 3600]");
  if (!(std::isfinite(aperture_f) && aperture_f >= 0.5 && aperture_f <= 256.0))
    return Fail(why, "aperture_f must be within [0.5, 256]");
  if (!(std::isfinite(iso) && iso > 0.0)) return Fail(why, "iso must be positive");
  if (!(std::isfinite(gain_db) && gain_db >= -20.0 && gain_db <= 60.0))
    return Fail(why, "gain_db must be within [-20, 60]");
  return true;
}

double ExposureParams::Gain(const CameraModelOptions& options) const {
  return (iso / options.base_iso) * std::pow(10.0, gain_db / 20.0);
}

double ElectronsPerRadiance(const PinholeIntrinsics& intrinsics, double x, double y, const ExposureParams& exposure,
                            const CameraModelOptions& options) {
  const double optics = std::numbers::pi / (4.0 * exposure.aperture_f * exposure.aperture_f);
  return optics * options.vignetting.Factor(intrinsics, x, y) * exposure.exposure_time_s *
         options.electrons_per_j_per_sqm;
}

namespace {

void CheckInputs(const PinholeIntrinsics& intrinsics, const ExposureParams& exposure,
                 const CameraModelOptions& options) {
  ThrowIfInvalid(options, "camera model options");
  ThrowIfInvalid(exposure, "exposure");
  ThrowIfInvalid(intrinsics, "camera intrinsics");
}

}  // namespace

cv::Mat ExpectedElectrons(const RadianceImage& radiance, const PinholeIntrinsics& intrinsics,
                          const ExposureParams& exposure, const CameraModelOptions& options) {
  CheckInputs(intrinsics, exposure, options);
  if (radiance.pixels.type() != CV_32FC3 || radiance.width() != intrinsics.width ||
      radiance.height() != intrinsics.height) {
    throw InvalidArgumentError("camera model: radiance must be CV_32FC3 of the camera's size " +
                               std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  }
  cv::Mat electrons(radiance.pixels.size(), CV_32FC3);
  const bool flat = options.vignetting.model == Vignetting::Model::kNone;
  const double on_axis = ElectronsPerRadiance(intrinsics, intrinsics.cx, intrinsics.cy, exposure, options);
  for (int y = 0; y < electrons.rows; ++y) {
    const float* in = radiance.pixels.ptr<float>(y);
    float* out = electrons.ptr<float>(y);
    for (int x = 0; x < electrons.cols; ++x) {
      const double scale = flat ? on_axis : ElectronsPerRadiance(intrinsics, x + 0.5, y + 0.5, exposure, options);
      for (int c = 0; c < 3; ++c) {
        // Non-finite or negative radiance is a renderer bug upstream; a sensor cannot see it.
        const float value = in[3 * x + c];
        out[3 * x + c] = std::isfinite(value) && value > 0.0f ? static_cast<float>(value * scale) : 0.0f;
      }
    }
  }
  return electrons;
}

cv::Mat AddSensorNoise(const cv::Mat& electrons, const CameraModelOptions& options, std::uint64_t seed) {
  ThrowIfInvalid(options, "camera model options");
  RELUME_CHECK(electrons.depth() == CV_32F);
  cv::Mat noisy = electrons.clone();
  const int samples_per_row = noisy.cols * noisy.channels();
  for (int y = 0; y < noisy.rows; ++y) {
    // One stream per row, so that rows can be computed in any order and still match.
    Rng rng(SplitMix64(seed ^ SplitMix64(static_cast<std::uint64_t>(y) + 0x9e3779b97f4a7c15ULL)));
    float* row = noisy.ptr<float>(y);
    for (int i = 0; i < samples_per_row; ++i) {
      const double mean = std::max(0.0, static_cast<double>(row[i]));
      const double sigma = std::sqrt((options.shot_noise ? mean : 0.0) + options.read_noise_e * options.read_noise_e);
      row[i] = static_cast<float>(mean + sigma * rng.Normal());
    }
  }
  return noisy;
}

namespace {

// Channel of a Bayer RGGB sample at (x, y).
int RggbChannel(int x, int y) {
  if ((y & 1) == 0) return (x & 1) == 0 ? 0 : 1;
  return (x & 1) == 0 ? 1 : 2;
}

template <typename T>
void WriteRaw(const cv::Mat& electrons, const ExposureParams& exposure, const CameraModelOptions& options,
              cv::Mat& out) {
  const double gain_counts = exposure.Gain(options) * options.counts_per_electron();
  const double black = options.black_level();
  const double white = options.white_level();
  const bool bayer = options.raw_layout == ColorLayout::kBayerRggb;
  for (int y = 0; y < electrons.rows; ++y) {
    const float* in = electrons.ptr<float>(y);
    T* row = out.ptr<T>(y);
    for (int x = 0; x < electrons.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        if (bayer && c != RggbChannel(x, y)) continue;
        const double e = std::clamp(static_cast<double>(in[3 * x + c]), 0.0, options.full_well_e);
        // Read noise can push a dark sample below the black level; the ADC clips at 0.
        const double counts = std::clamp(std::nearbyint(black + e * gain_counts), 0.0, white);
        row[bayer ? x : 3 * x + c] = static_cast<T>(counts);
      }
    }
  }
}

}  // namespace

CameraImage RawFromElectrons(const cv::Mat& electrons, const ExposureParams& exposure,
                             const CameraModelOptions& options) {
  ThrowIfInvalid(options, "camera model options");
  ThrowIfInvalid(exposure, "exposure");
  RELUME_CHECK(electrons.type() == CV_32FC3);
  CameraImage image;
  image.layout = options.raw_layout;
  image.encoding = SampleEncoding::kSensorLinear;
  image.bits_per_sample = options.raw_bits;
  image.black_level = options.black_level();
  image.white_level = options.white_level();
  const int channels = options.raw_layout == ColorLayout::kRgb ? 3 : 1;
  if (options.raw_bits == 8) {
    image.pixels.create(electrons.size(), CV_MAKETYPE(CV_8U, channels));
    WriteRaw<std::uint8_t>(electrons, exposure, options, image.pixels);
  } else {
    image.pixels.create(electrons.size(), CV_MAKETYPE(CV_16U, channels));
    WriteRaw<std::uint16_t>(electrons, exposure, options, image.pixels);
  }
  return image;
}

CameraImage EncodedFromElectrons(const cv::Mat& electrons, const ExposureParams& exposure,
                                 const CameraModelOptions& options) {
  ThrowIfInvalid(options, "camera model options");
  ThrowIfInvalid(exposure, "exposure");
  RELUME_CHECK(electrons.type() == CV_32FC3);
  // Code c is output for x in [Decode((c - 0.5) / 255), Decode((c + 0.5) / 255)): counting the
  // thresholds at or below x gives round(255 * Encode(x)) without evaluating the curve per
  // sample. Thresholds are in electrons-times-gain to save a division per sample.
  std::array<double, 255> thresholds;
  for (int c = 0; c < 255; ++c) thresholds[c] = options.response.Decode((c + 0.5) / 255.0) * options.full_well_e;
  const double gain = exposure.Gain(options);
  CameraImage image;
  image.layout = ColorLayout::kRgb;
  image.encoding = SampleEncoding::kCameraResponse;
  image.bits_per_sample = 8;
  image.black_level = 0;
  image.white_level = 255;
  image.pixels.create(electrons.size(), CV_8UC3);
  for (int y = 0; y < electrons.rows; ++y) {
    const float* in = electrons.ptr<float>(y);
    std::uint8_t* out = image.pixels.ptr<std::uint8_t>(y);
    for (int i = 0; i < 3 * electrons.cols; ++i) {
      const double signal = std::min(static_cast<double>(in[i]), options.full_well_e) * gain;
      out[i] = static_cast<std::uint8_t>(std::upper_bound(thresholds.begin(), thresholds.end(), signal) -
                                         thresholds.begin());
    }
  }
  return image;
}

double SaturationRadiance(const PinholeIntrinsics& intrinsics, double x, double y, const ExposureParams& exposure,
                          const CameraModelOptions& options) {
  return options.full_well_e / exposure.Gain(options) / ElectronsPerRadiance(intrinsics, x, y, exposure, options);
}

double RadianceFromRawCount(int count, const PinholeIntrinsics& intrinsics, double x, double y,
                            const ExposureParams& exposure, const CameraModelOptions& options) {
  if (count >= options.white_level()) return NAN;
  const double electrons =
      std::max(0, count - options.black_level()) / (options.counts_per_electron() * exposure.Gain(options));
  return electrons / ElectronsPerRadiance(intrinsics, x, y, exposure, options);
}

double RadianceFromEncodedValue(int value, const PinholeIntrinsics& intrinsics, double x, double y,
                                const ExposureParams& exposure, const CameraModelOptions& options) {
  if (value >= 255) return NAN;
  const double electrons = options.response.Decode(value / 255.0) * options.full_well_e / exposure.Gain(options);
  return electrons / ElectronsPerRadiance(intrinsics, x, y, exposure, options);
}

RadianceImage RadianceFromCameraImage(const CameraImage& image, const PinholeIntrinsics& intrinsics,
                                      const ExposureParams& exposure, const CameraModelOptions& options) {
  CheckInputs(intrinsics, exposure, options);
  std::string why;
  if (!image.IsValid(&why)) throw InvalidArgumentError("camera image: " + why);
  if (image.layout != ColorLayout::kRgb)
    throw InvalidArgumentError("RadianceFromCameraImage needs an RGB image; use RadianceFromRawCount per sample");
  RadianceImage radiance = MakeRadianceImage(image.width(), image.height(), RadianceUnit::kWattsPerSqmPerSr);
  const bool raw = image.encoding == SampleEncoding::kSensorLinear;
  for (int y = 0; y < image.height(); ++y) {
    float* out = radiance.pixels.ptr<float>(y);
    for (int x = 0; x < image.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        const int value = image.pixels.depth() == CV_8U ? image.pixels.ptr<std::uint8_t>(y)[3 * x + c]
                                                        : image.pixels.ptr<std::uint16_t>(y)[3 * x + c];
        const double r = raw ? RadianceFromRawCount(value, intrinsics, x + 0.5, y + 0.5, exposure, options)
                             : RadianceFromEncodedValue(value, intrinsics, x + 0.5, y + 0.5, exposure, options);
        out[3 * x + c] = static_cast<float>(r);
      }
    }
  }
  return radiance;
}

}  // namespace relume::sim
