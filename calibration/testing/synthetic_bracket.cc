#include "calibration/testing/synthetic_bracket.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>

#include "core/error.h"

namespace relume::calibration::testing {

const char* ToString(ResponseShape shape) {
  switch (shape) {
    case ResponseShape::kGamma: return "gamma";
    case ResponseShape::kSCurve: return "s-curve";
    case ResponseShape::kTable: return "table";
    case ResponseShape::kSrgb: return "srgb";
    case ResponseShape::kRec709: return "rec709";
    case ResponseShape::kSrgbSTone: return "srgb+s-tone";
    case ResponseShape::kLogEncoding: return "log";
    case ResponseShape::kRandom: return "random";
  }
  return "unknown";
}

namespace {
// A small per-channel difference for the standard encodings: 0.96, 1.0, 1.04.
double ChannelTint(int channel) {
  return 1.0 + 0.04 * (channel % 3 - 1);
}
}  // namespace

double RandomCurve::Forward(double x) const {
  x = std::clamp(x, 0.0, 1.0);
  double y = 0.0;
  if (w_power > 0.0) y += w_power * std::pow(x, 1.0 / gamma);
  if (w_srgb > 0.0) {
    // Linear toe k x up to b, then (1 + a) x^p - a; value and slope continuous at b.
    const double p = srgb_power, b = srgb_break;
    const double bp = std::pow(b, p);
    const double a = bp * (1.0 - p) / (1.0 - bp * (1.0 - p));
    const double k = (1.0 + a) * p * std::pow(b, p - 1.0);
    y += w_srgb * (x <= b ? k * x : (1.0 + a) * std::pow(x, p) - a);
  }
  if (w_s > 0.0) {
    const double xs = std::pow(x, s_slope), ms = std::pow(s_mid, s_slope);
    y += w_s * xs / (xs + ms) * (1.0 + ms);
  }
  if (w_log > 0.0) y += w_log * std::log1p(log_k * x) / std::log1p(log_k);
  y = std::clamp(y, 0.0, 1.0);
  y = (1.0 - contrast) * y + contrast * y * y * (3.0 - 2.0 * y);
  double wiggled = y;
  for (std::size_t k = 0; k < wiggle.size(); ++k) {
    const double kpi = static_cast<double>(k + 1) * std::numbers::pi;
    wiggled += wiggle[k] * std::sin(kpi * y) / kpi;
  }
  return std::clamp(wiggled, 0.0, 1.0);
}

double SyntheticResponse::Forward(int channel, double x) const {
  x = std::clamp(x, 0.0, 1.0);
  switch (shape) {
    case ResponseShape::kGamma: return std::pow(x, 1.0 / 2.2);
    case ResponseShape::kSCurve: {
      const std::array<double, 3> s = {1.5, 1.7, 1.9};
      const double m = 0.3;
      const double k = s[channel % 3];
      const double xm = std::pow(m, k);
      return std::pow(x, k) / (std::pow(x, k) + xm) * (1.0 + xm);
    }
    case ResponseShape::kTable: {
      // Knots (x, y); the y values differ slightly per channel.
      static const std::array<double, 7> kx = {0.0, 0.01, 0.05, 0.15, 0.35, 0.65, 1.0};
      static const std::array<std::array<double, 7>, 3> ky = {{{0.0, 0.08, 0.25, 0.46, 0.68, 0.87, 1.0},
                                                               {0.0, 0.10, 0.28, 0.48, 0.70, 0.88, 1.0},
                                                               {0.0, 0.06, 0.22, 0.43, 0.66, 0.86, 1.0}}};
      const auto& y = ky[channel % 3];
      for (std::size_t i = 1; i < kx.size(); ++i) {
        if (x <= kx[i]) return y[i - 1] + (y[i] - y[i - 1]) * (x - kx[i - 1]) / (kx[i] - kx[i - 1]);
      }
      return 1.0;
    }
    case ResponseShape::kSrgb: {
      const double exponent = 1.0 / (2.4 * ChannelTint(channel));
      return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, exponent) - 0.055;
    }
    case ResponseShape::kRec709: {
      const double exponent = 0.45 * ChannelTint(channel);
      return x < 0.018 ? 4.5 * x : 1.099 * std::pow(x, exponent) - 0.099;
    }
    case ResponseShape::kSrgbSTone: {
      const double y = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
      const double contrast = 0.35 * ChannelTint(channel);
      return (1.0 - contrast) * y + contrast * y * y * (3.0 - 2.0 * y);
    }
    case ResponseShape::kLogEncoding: {
      const double k = 100.0 * ChannelTint(channel);
      return std::log10(1.0 + k * x) / std::log10(1.0 + k);
    }
    case ResponseShape::kRandom: return curves[static_cast<std::size_t>(channel % 3)].Forward(x);
  }
  return x;
}

namespace {

// [0, 1) from std::mt19937_64's raw output, bit for bit what libstdc++'s
// std::uniform_real_distribution<double>(0, 1) gives with that engine (one draw, x / 2^64,
// kept below 1), but specified here so every standard library gives the same numbers.
double Unit(std::mt19937_64& rng) {
  const double u = static_cast<double>(rng()) * 0x1.0p-64;
  return u < 1.0 ? u : std::nextafter(1.0, 0.0);
}
double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * Unit(rng);
}
double LogUniform(std::mt19937_64& rng, double lo, double hi) {
  return std::exp(Uniform(rng, std::log(lo), std::log(hi)));
}

enum Family { kPower, kSrgbLike, kS, kLog, kFamilies };
const char* FamilyName(int family) {
  static const char* const names[] = {"power", "srgb-like", "s-curve", "log"};
  return names[family];
}
double& Weight(RandomCurve& c, int family) {
  switch (family) {
    case kPower: return c.w_power;
    case kSrgbLike: return c.w_srgb;
    case kS: return c.w_s;
    default: return c.w_log;
  }
}
double WeightOf(const RandomCurve& c, int family) {
  switch (family) {
    case kPower: return c.w_power;
    case kSrgbLike: return c.w_srgb;
    case kS: return c.w_s;
    default: return c.w_log;
  }
}

}  // namespace

SyntheticResponse RandomResponse(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  // The camera: one family, or two mixed; parameters; contrast; wiggle amplitude.
  const int first = static_cast<int>(rng() % kFamilies);
  int second = -1;
  double second_weight = 0.0;
  if (Unit(rng) < 0.6) {
    second = (first + 1 + static_cast<int>(rng() % (kFamilies - 1))) % kFamilies;
    second_weight = Uniform(rng, 0.2, 0.5);
  }
  RandomCurve camera;
  camera.w_power = 0.0;
  camera.gamma = Uniform(rng, 1.6, 2.8);
  camera.srgb_power = 1.0 / Uniform(rng, 1.9, 2.8);
  camera.srgb_break = LogUniform(rng, 0.001, 0.02);
  camera.s_slope = Uniform(rng, 1.2, 2.2);
  camera.s_mid = Uniform(rng, 0.15, 0.5);
  camera.log_k = LogUniform(rng, 10.0, 1000.0);
  camera.contrast = Unit(rng) < 0.5 ? Uniform(rng, -0.3, 0.5) : 0.0;
  const double wiggle = Unit(rng) < 0.7 ? Uniform(rng, 0.0, 0.3) : 0.0;
  SyntheticResponse response;
  response.shape = ResponseShape::kRandom;
  for (RandomCurve& c : response.curves) {
    c = camera;
    const double w2 = second < 0 ? 0.0 : std::clamp(second_weight + Uniform(rng, -0.05, 0.05), 0.1, 0.6);
    Weight(c, first) = 1.0 - w2;
    if (second >= 0) Weight(c, second) = w2;
    c.gamma *= 1.0 + Uniform(rng, -0.08, 0.08);
    c.srgb_power *= 1.0 + Uniform(rng, -0.08, 0.08);
    c.s_slope *= 1.0 + Uniform(rng, -0.08, 0.08);
    c.s_mid *= 1.0 + Uniform(rng, -0.1, 0.1);
    c.log_k *= 1.0 + Uniform(rng, -0.2, 0.2);
    if (camera.contrast != 0.0) c.contrast = std::clamp(camera.contrast + Uniform(rng, -0.05, 0.05), -0.3, 0.5);
    // Wiggles: decreasing with k, random signs, sum |a_k| = the channel's amplitude (< 1).
    double sum = 0.0;
    for (std::size_t k = 0; k < c.wiggle.size(); ++k) {
      c.wiggle[k] = Uniform(rng, -1.0, 1.0) / static_cast<double>(k + 1);
      sum += std::abs(c.wiggle[k]);
    }
    const double amplitude = wiggle * (1.0 + Uniform(rng, -0.2, 0.2));
    for (double& a : c.wiggle) a = sum > 0.0 ? a * amplitude / sum : 0.0;
  }
  return response;
}

std::string DescribeResponse(const SyntheticResponse& response) {
  if (response.shape != ResponseShape::kRandom) return ToString(response.shape);
  auto range = [&](auto get, int precision) {
    double lo = get(response.curves[0]), hi = lo;
    for (const RandomCurve& c : response.curves) {
      lo = std::min(lo, get(c));
      hi = std::max(hi, get(c));
    }
    std::ostringstream s;
    s << std::fixed << std::setprecision(precision) << lo;
    if (hi - lo >= std::pow(10.0, -precision)) s << " to " << hi;
    return s.str();
  };
  std::ostringstream s;
  bool any = false;
  for (int f = 0; f < kFamilies; ++f) {
    if (WeightOf(response.curves[0], f) <= 0.0) continue;
    s << (any ? " + " : "") << range([f](const RandomCurve& c) { return WeightOf(c, f); }, 2) << " " << FamilyName(f);
    switch (f) {
      case kPower: s << " (gamma " << range([](const RandomCurve& c) { return c.gamma; }, 2) << ")"; break;
      case kSrgbLike:
        s << " (1/p " << range([](const RandomCurve& c) { return 1.0 / c.srgb_power; }, 2) << ", toe "
          << range([](const RandomCurve& c) { return c.srgb_break; }, 4) << ")";
        break;
      case kS:
        s << " (s " << range([](const RandomCurve& c) { return c.s_slope; }, 2) << ", m "
          << range([](const RandomCurve& c) { return c.s_mid; }, 2) << ")";
        break;
      default: s << " (k " << range([](const RandomCurve& c) { return c.log_k; }, 0) << ")"; break;
    }
    any = true;
  }
  s << ", contrast " << range([](const RandomCurve& c) { return c.contrast; }, 2) << ", wiggle "
    << range(
           [](const RandomCurve& c) {
             double a = 0.0;
             for (const double w : c.wiggle) a += std::abs(w);
             return a;
           },
           2);
  return s.str();
}

double SyntheticResponse::Inverse(int channel, double y) const {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (Forward(channel, mid) < y ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

cv::Mat MakeHdrRadiance(const SceneOptions& options) {
  RELUME_CHECK(options.width > 0 && options.height > 0 && options.dynamic_range > 1.0);
  cv::Mat radiance(options.height, options.width, CV_32FC3);
  std::mt19937_64 rng(options.seed);
  auto unit = [](std::mt19937_64& engine) { return Unit(engine); };  // portable, see Unit
  // Patches of 24 x 24 pixels: log-uniform brightness, random colour (chroma kept moderate so
  // no channel is far darker than the others), each with a smooth 2x diagonal gradient so that
  // every patch covers a range of codes.
  const int patch = 24;
  const int px = (options.width + patch - 1) / patch, py = (options.height + patch - 1) / patch;
  std::vector<cv::Vec3f> colours(static_cast<std::size_t>(px) * py);
  const double log_range = std::log(options.dynamic_range);
  for (auto& c : colours) {
    const double level = std::exp(-log_range * unit(rng));  // (1/range, 1]
    for (int k = 0; k < 3; ++k) c[k] = static_cast<float>(level * (0.55 + 0.45 * unit(rng)));
  }
  for (int y = 0; y < options.height; ++y) {
    auto* row = radiance.ptr<cv::Vec3f>(y);
    for (int x = 0; x < options.width; ++x) {
      const double u = ((x % patch) + (y % patch)) / (2.0 * patch);  // [0, 1) across the patch
      const float ramp = static_cast<float>(std::exp2(u - 1.0));     // [0.5, 1)
      row[x] = colours[static_cast<std::size_t>(y / patch) * px + x / patch] * ramp;
    }
  }
  return radiance;
}

std::vector<double> BracketExposures(int count, double stops, double middle_s) {
  std::vector<double> t;
  for (int i = 0; i < count; ++i) t.push_back(middle_s * std::exp2(stops * (i - (count - 1) / 2.0)));
  return t;
}

std::vector<double> UnequalBracketExposures(int count, double stops, double middle_s, double d) {
  const double span = stops * (count - 1);
  std::vector<double> gaps;
  double total = 0.0;
  for (int i = 0; i + 1 < count; ++i) {
    gaps.push_back(1.0 + (i % 2 == 0 ? d : -d));
    total += gaps.back();
  }
  std::vector<double> t;
  double at = -0.5 * span;
  for (int i = 0; i < count; ++i) {
    t.push_back(middle_s * std::exp2(at));
    if (i + 1 < count) at += gaps[static_cast<std::size_t>(i)] * span / total;
  }
  return t;
}

cv::Mat IdealExposure(const cv::Mat& radiance, double exposure_time_s) {
  return radiance * exposure_time_s;
}

cv::Mat AddSensorNoise(const cv::Mat& exposure, const NoiseOptions& noise, std::uint64_t frame_index) {
  cv::Mat out = exposure.clone();
  if (noise.shot_noise <= 0.0 && noise.read_noise <= 0.0) return out;
  cv::Mat gauss(exposure.size(), exposure.type());
  cv::RNG rng(noise.seed * 1000003ULL + frame_index);
  rng.fill(gauss, cv::RNG::NORMAL, 0.0, 1.0);
  const int n = static_cast<int>(exposure.total() * exposure.channels());
  float* o = out.ptr<float>();
  const float* g = gauss.ptr<float>();
  for (int i = 0; i < n; ++i) {
    const double x = std::max(0.0f, o[i]);
    const double sigma = std::sqrt(noise.shot_noise * x + noise.read_noise * noise.read_noise);
    o[i] = static_cast<float>(x + sigma * g[i]);
  }
  return out;
}

CameraImage EncodeFrame(const cv::Mat& exposure, const SyntheticResponse& response) {
  RELUME_CHECK(exposure.type() == CV_32FC3);
  // A 4096-entry table of the forward response per channel keeps encoding fast.
  constexpr int kTable = 4096;
  std::array<std::vector<std::uint8_t>, 3> table;
  for (int c = 0; c < 3; ++c) {
    table[c].resize(kTable + 1);
    for (int i = 0; i <= kTable; ++i) {
      table[c][i] = static_cast<std::uint8_t>(std::lround(255.0 * response.Forward(c, (i + 0.0) / kTable)));
    }
  }
  CameraImage image;
  image.pixels = cv::Mat(exposure.size(), CV_8UC3);
  image.layout = ColorLayout::kRgb;
  image.encoding = SampleEncoding::kCameraResponse;
  image.bits_per_sample = 8;
  image.black_level = 0;
  image.white_level = 255;
  for (int y = 0; y < exposure.rows; ++y) {
    const float* in = exposure.ptr<float>(y);
    std::uint8_t* out = image.pixels.ptr<std::uint8_t>(y);
    for (int i = 0; i < exposure.cols * 3; ++i) {
      const int c = i % 3;
      const double x = std::clamp(static_cast<double>(in[i]), 0.0, 1.0);
      // Exact forward response for dark values (the table is coarse where gamma is steep).
      out[i] = x < 0.05 ? static_cast<std::uint8_t>(std::lround(255.0 * response.Forward(c, x)))
                        : table[c][static_cast<int>(std::lround(x * kTable))];
    }
  }
  return image;
}

std::vector<CameraImage> RenderBracket(const cv::Mat& radiance, const std::vector<double>& exposure_times_s,
                                       const SyntheticResponse& response, const NoiseOptions& noise) {
  std::vector<CameraImage> frames;
  for (std::size_t i = 0; i < exposure_times_s.size(); ++i) {
    frames.push_back(EncodeFrame(AddSensorNoise(IdealExposure(radiance, exposure_times_s[i]), noise, i), response));
  }
  return frames;
}

CameraResponse TrueInverseResponse(const SyntheticResponse& response) {
  CameraResponse r;
  r.levels = 256;
  r.inverse.assign(3, std::vector<double>(256));
  for (int c = 0; c < 3; ++c) {
    const double mid = response.Inverse(c, 128.0 / 255.0);
    for (int z = 0; z < 256; ++z) r.inverse[c][z] = response.Inverse(c, z / 255.0) / mid;
    r.inverse[c][0] = 0.0;
  }
  return r;
}

cv::Mat WellExposedMask(const cv::Mat& radiance, const std::vector<double>& exposure_times_s,
                        const SyntheticResponse& response, int low_code, int high_code) {
  cv::Mat mask = cv::Mat::zeros(radiance.size(), CV_8UC1);
  for (double t : exposure_times_s) {
    const CameraImage frame = EncodeFrame(IdealExposure(radiance, t), response);
    for (int y = 0; y < radiance.rows; ++y) {
      const std::uint8_t* p = frame.pixels.ptr<std::uint8_t>(y);
      std::uint8_t* m = mask.ptr<std::uint8_t>(y);
      for (int x = 0; x < radiance.cols; ++x) {
        bool good = true;
        for (int c = 0; c < 3; ++c) good = good && p[3 * x + c] >= low_code && p[3 * x + c] <= high_code;
        if (good) m[x] = 255;
      }
    }
  }
  return mask;
}

RadianceError CompareRadiance(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask) {
  RELUME_CHECK(estimate.size() == truth.size() && estimate.type() == CV_32FC3 && truth.type() == CV_32FC3);
  RadianceError error;
  // Per-channel scale: median of truth / estimate over the mask (robust to outliers).
  std::array<double, 3> scale{1.0, 1.0, 1.0};
  for (int c = 0; c < 3; ++c) {
    std::vector<double> ratios;
    for (int y = 0; y < truth.rows; ++y) {
      for (int x = 0; x < truth.cols; ++x) {
        if (!mask.at<std::uint8_t>(y, x)) continue;
        const double e = estimate.at<cv::Vec3f>(y, x)[c];
        if (e > 0.0 && std::isfinite(e)) ratios.push_back(truth.at<cv::Vec3f>(y, x)[c] / e);
      }
    }
    if (ratios.empty()) return error;
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    scale[c] = ratios[ratios.size() / 2];
  }
  std::vector<double> errors;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (!mask.at<std::uint8_t>(y, x)) continue;
      ++error.pixels;
      for (int c = 0; c < 3; ++c) {
        const double t = truth.at<cv::Vec3f>(y, x)[c];
        const double e = estimate.at<cv::Vec3f>(y, x)[c];
        errors.push_back(std::isfinite(e) ? std::abs(scale[c] * e - t) / t : 1.0);
      }
    }
  }
  if (errors.empty()) return error;
  double sum = 0.0;
  for (double e : errors) sum += e;
  error.mean_relative = sum / errors.size();
  std::nth_element(errors.begin(), errors.begin() + errors.size() * 95 / 100, errors.end());
  error.p95_relative = errors[errors.size() * 95 / 100];
  return error;
}

}  // namespace relume::calibration::testing
