#include "calibration/report_plots.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace relume::calibration {

cv::Mat PlotResponse(const CameraResponse& response, int width, int height) {
  cv::Mat canvas(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 50, right = 15, top = 15, bottom = 35;
  double lo = 1e30, hi = -1e30;
  for (const auto& curve : response.inverse) {
    for (int z = 1; z < response.levels; ++z) {
      if (curve[z] > 0) {
        lo = std::min(lo, std::log2(curve[z]));
        hi = std::max(hi, std::log2(curve[z]));
      }
    }
  }
  if (!(hi > lo)) {
    lo = -1;
    hi = 1;
  }
  auto px = [&](double z, double log_x) {
    return cv::Point(static_cast<int>(left + (width - left - right) * z / (response.levels - 1)),
                     static_cast<int>(height - bottom - (height - top - bottom) * (log_x - lo) / (hi - lo)));
  };
  cv::rectangle(canvas, {left, top}, {width - right, height - bottom}, cv::Scalar(0, 0, 0));
  for (int ev = static_cast<int>(std::ceil(lo)); ev <= static_cast<int>(std::floor(hi)); ++ev) {
    const cv::Point a = px(0, ev);
    cv::line(canvas, {left, a.y}, {width - right, a.y}, cv::Scalar(220, 220, 220));
    cv::putText(canvas, std::to_string(ev), {5, a.y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  }
  cv::putText(canvas, "code", {width / 2, height - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
  cv::putText(canvas, "log2 X", {left + 5, top + 15}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
  const cv::Scalar colours[3] = {cv::Scalar(220, 0, 0), cv::Scalar(0, 160, 0), cv::Scalar(0, 0, 220)};
  for (int c = 0; c < response.channels(); ++c) {
    std::vector<cv::Point> line;
    for (int z = 1; z < response.levels; ++z) {
      if (response.inverse[c][z] > 0) line.push_back(px(z, std::log2(response.inverse[c][z])));
    }
    cv::polylines(canvas, line, false, response.channels() == 1 ? cv::Scalar(0, 0, 0) : colours[c], 2, cv::LINE_AA);
  }
  return canvas;
}

cv::Mat DrawChart(const cv::Mat& rgb8, const ChartLocation& location, const std::vector<PatchSample>& patches) {
  cv::Mat canvas = rgb8.clone();
  std::vector<cv::Point> outline;
  for (const auto& p : location.corners) outline.emplace_back(cvRound(p.x), cvRound(p.y));
  cv::polylines(canvas, outline, true, cv::Scalar(255, 255, 0), 2, cv::LINE_AA);
  cv::circle(canvas, outline[0], 5, cv::Scalar(255, 0, 255), 2);  // dark skin's corner
  for (std::size_t k = 0; k < patches.size(); ++k) {
    std::vector<cv::Point> quad;
    for (const auto& p : patches[k].inner_quad) quad.emplace_back(cvRound(p.x), cvRound(p.y));
    const cv::Scalar colour = patches[k].status == PatchStatus::kOk ? cv::Scalar(0, 255, 0) : cv::Scalar(255, 0, 0);
    cv::polylines(canvas, quad, true, colour, 1, cv::LINE_AA);
    cv::putText(canvas, std::to_string(k + 1), quad[0] + cv::Point(2, 10), cv::FONT_HERSHEY_SIMPLEX, 0.3, colour);
  }
  return canvas;
}

namespace {
cv::Scalar Encode(const Eigen::Vector3d& linear) {
  auto e = [](double v) { return 255.0 * SrgbEncode(std::clamp(v, 0.0, 1.0)); };
  return cv::Scalar(e(linear[0]), e(linear[1]), e(linear[2]));
}
}  // namespace

cv::Mat DrawSwatches(const ColorFit& fit, const ColorCheckerReference& reference, int cell) {
  cv::Mat canvas(4 * cell, 6 * cell, CV_8UC3, cv::Scalar(30, 30, 30));
  for (int k = 0; k < 24; ++k) {
    const int x = (k % 6) * cell, y = (k / 6) * cell;
    const int m = cell / 10;
    cv::rectangle(canvas, cv::Rect(x + m, y + m, cell / 2 - m, cell - 2 * m), Encode(fit.patches[k].corrected),
                  cv::FILLED);
    cv::rectangle(canvas, cv::Rect(x + cell / 2, y + m, cell / 2 - m, cell - 2 * m),
                  Encode(reference.patches[k].linear_rgb), cv::FILLED);
    if (!fit.patches[k].used) {
      cv::line(canvas, {x + m, y + m}, {x + cell - m, y + cell - m}, cv::Scalar(255, 0, 0), 2);
    } else {
      char text[16];
      std::snprintf(text, sizeof(text), "%.1f", fit.patches[k].delta_e);
      cv::putText(canvas, text, {x + m + 2, y + cell - m - 4}, cv::FONT_HERSHEY_SIMPLEX, 0.35,
                  cv::Scalar(255, 255, 255), 2);
      cv::putText(canvas, text, {x + m + 2, y + cell - m - 4}, cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0), 1);
    }
  }
  return canvas;
}

cv::Mat PreviewLinear(const cv::Mat& linear_rgb) {
  std::vector<float> values;
  for (int y = 0; y < linear_rgb.rows; y += 2) {
    for (int x = 0; x < linear_rgb.cols; x += 2) {
      const cv::Vec3f v = linear_rgb.at<cv::Vec3f>(y, x);
      const float m = std::max({v[0], v[1], v[2]});
      if (std::isfinite(m)) values.push_back(m);
    }
  }
  double scale = 1.0;
  if (!values.empty()) {
    std::nth_element(values.begin(), values.begin() + values.size() * 99 / 100, values.end());
    const double p99 = values[values.size() * 99 / 100];
    if (p99 > 0) scale = 1.0 / p99;
  }
  cv::Mat out(linear_rgb.size(), CV_8UC3);
  for (int y = 0; y < linear_rgb.rows; ++y) {
    for (int x = 0; x < linear_rgb.cols; ++x) {
      const cv::Vec3f v = linear_rgb.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double lv = std::isfinite(v[c]) ? std::clamp(v[c] * scale, 0.0, 1.0) : 0.0;
        out.at<cv::Vec3b>(y, x)[c] = static_cast<std::uint8_t>(std::lround(255.0 * SrgbEncode(lv)));
      }
    }
  }
  return out;
}

}  // namespace relume::calibration
