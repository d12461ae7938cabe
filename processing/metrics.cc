#include "processing/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace relume::metrics {

SunRegion ClassifySunRegion(float source_fraction, float target_fraction) {
  const auto partial = [](float f) { return f > 0.01f && f < 0.99f; };
  if (partial(source_fraction) || partial(target_fraction)) return SunRegion::kPenumbra;
  if (source_fraction >= 0.99f && target_fraction >= 0.99f) return SunRegion::kLit;
  return SunRegion::kShadow;
}

namespace {

bool Finite(const cv::Vec3f& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

}  // namespace

SunRegionErrors CompareSunRegions(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& source_sun,
                                  const cv::Mat& target_sun, const cv::Mat& use, Scale scale, cv::Mat* error_image) {
  RELUME_CHECK(estimate.type() == CV_32FC3 && truth.type() == CV_32FC3 && estimate.size() == truth.size());
  RELUME_CHECK(source_sun.size() == truth.size() && target_sun.size() == truth.size() && use.size() == truth.size());
  const auto usable = [&](int x, int y) {
    if (use.at<std::uint8_t>(y, x) == 0) return false;
    const cv::Vec3f& e = estimate.at<cv::Vec3f>(y, x);
    const cv::Vec3f& t = truth.at<cv::Vec3f>(y, x);
    return Finite(e) && Finite(t) && t[0] > 0.0f && t[1] > 0.0f && t[2] > 0.0f;
  };
  // The per-sample measure's scale: minimise sum (a q - 1)^2 with q = e / t: a = sum q / sum q^2.
  double sq = 0.0, sqq = 0.0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (!usable(x, y)) continue;
      for (int c = 0; c < 3; ++c) {
        const double q = estimate.at<cv::Vec3f>(y, x)[c] / truth.at<cv::Vec3f>(y, x)[c];
        sq += q;
        sqq += q * q;
      }
    }
  }
  SunRegionErrors errors;
  if (!(sqq > 0.0)) return errors;
  errors.scale = scale == Scale::kFitted ? sq / sqq : 1.0;
  double lit = 0.0, shadow = 0.0, penumbra = 0.0;
  if (error_image != nullptr) *error_image = cv::Mat(truth.rows, truth.cols, CV_8UC3, cv::Scalar::all(0));
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (!usable(x, y)) continue;
      double e2 = 0.0;
      for (int c = 0; c < 3; ++c) {
        const double q = estimate.at<cv::Vec3f>(y, x)[c] / truth.at<cv::Vec3f>(y, x)[c];
        e2 += (errors.scale * q - 1.0) * (errors.scale * q - 1.0) / 3.0;
      }
      const SunRegion region = ClassifySunRegion(source_sun.at<float>(y, x), target_sun.at<float>(y, x));
      if (error_image != nullptr) {
        const double v = std::min(1.0, std::sqrt(e2) * 10.0) * 255.0;
        const auto u8 = [](double value) { return static_cast<std::uint8_t>(std::min(255.0, value)); };
        const bool is_lit = region == SunRegion::kLit, is_penumbra = region == SunRegion::kPenumbra;
        error_image->at<cv::Vec3b>(y, x) = cv::Vec3b(u8(is_lit || is_penumbra ? v : 0.3 * v), u8(is_lit ? v : 0.3 * v),
                                                     u8(is_lit ? v : (is_penumbra ? 0.3 * v : v + 40)));
      }
      switch (region) {
        case SunRegion::kPenumbra:
          penumbra += e2;
          ++errors.penumbra_pixels;
          break;
        case SunRegion::kLit:
          lit += e2;
          ++errors.lit_pixels;
          break;
        case SunRegion::kShadow:
          shadow += e2;
          ++errors.shadow_pixels;
          break;
      }
    }
  }
  const auto rms = [](double sum, std::int64_t n) { return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0; };
  errors.lit = rms(lit, errors.lit_pixels);
  errors.shadow = rms(shadow, errors.shadow_pixels);
  errors.penumbra = rms(penumbra, errors.penumbra_pixels);
  errors.all = rms(lit + shadow + penumbra, errors.lit_pixels + errors.shadow_pixels + errors.penumbra_pixels);
  return errors;
}

SignalError SignalRelativeRms(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask, Scale scale) {
  RELUME_CHECK(estimate.type() == CV_32FC3 && truth.type() == CV_32FC3 && estimate.size() == truth.size());
  RELUME_CHECK(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == truth.size()));
  double et = 0.0, ee = 0.0, tt = 0.0;
  SignalError out;
  for (int pass = 0; pass < 2; ++pass) {
    double diff = 0.0;
    for (int y = 0; y < truth.rows; ++y) {
      const auto* e = estimate.ptr<cv::Vec3f>(y);
      const auto* t = truth.ptr<cv::Vec3f>(y);
      const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
      for (int x = 0; x < truth.cols; ++x) {
        if ((m != nullptr && m[x] == 0) || !Finite(e[x]) || !Finite(t[x])) continue;
        for (int c = 0; c < 3; ++c) {
          if (pass == 0) {
            et += static_cast<double>(e[x][c]) * t[x][c];
            ee += static_cast<double>(e[x][c]) * e[x][c];
            tt += static_cast<double>(t[x][c]) * t[x][c];
          } else {
            const double d = out.scale * e[x][c] - t[x][c];
            diff += d * d;
          }
        }
        if (pass == 0) ++out.pixels;
      }
    }
    if (pass == 0) {
      // Signal measure's scale: minimise sum (a e - t)^2: a = sum e t / sum e^2.
      out.scale = scale == Scale::kFitted && ee > 0.0 ? et / ee : 1.0;
    } else {
      out.relative_rms = tt > 0.0 ? std::sqrt(diff / tt) : std::numeric_limits<double>::quiet_NaN();
    }
  }
  return out;
}

}  // namespace relume::metrics
