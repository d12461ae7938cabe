#include "calibration/testing/synthetic_chart.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace relume::calibration::testing {

cv::Mat RenderChartRadiance(const ColorCheckerReference& chart, const ChartSceneOptions& options) {
  std::vector<cv::Point2f> grid = {{0, 0}, {6, 0}, {6, 4}, {0, 4}};
  std::vector<cv::Point2f> image(options.corners.begin(), options.corners.end());
  const cv::Matx33d grid_from_image = cv::Matx33d(cv::getPerspectiveTransform(image, grid));
  cv::Mat out(options.height, options.width, CV_32FC3);
  constexpr int kSuper = 4;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      cv::Vec3d sum(0, 0, 0);
      for (int sy = 0; sy < kSuper; ++sy) {
        for (int sx = 0; sx < kSuper; ++sx) {
          const cv::Vec3d p(x + (sx + 0.5) / kSuper, y + (sy + 0.5) / kSuper, 1.0);
          const cv::Vec3d q = grid_from_image * p;
          const double u = q[0] / q[2], v = q[1] / q[2];
          cv::Vec3d reflectance = cv::Vec3d::all(options.background);
          if (u > -options.border && u < 6 + options.border && v > -options.border && v < 4 + options.border) {
            reflectance = cv::Vec3d::all(0.03);
            const int col = static_cast<int>(std::floor(u)), row = static_cast<int>(std::floor(v));
            const double fu = u - col, fv = v - row;
            const double g = options.gap / 2;
            if (col >= 0 && col < 6 && row >= 0 && row < 4 && fu > g && fu < 1 - g && fv > g && fv < 1 - g) {
              const LinearRgb& rgb = chart.patches[row * 6 + col].linear_rgb;
              reflectance = cv::Vec3d(rgb.x(), rgb.y(), rgb.z());
            }
          }
          double shade = 1.0;
          if (options.shadow_x >= 0 && p[0] < options.shadow_x) shade = options.shadow_factor;
          sum += reflectance.mul(options.light) * shade;
        }
      }
      out.at<cv::Vec3f>(y, x) = cv::Vec3f(sum / (kSuper * kSuper));
    }
  }
  return out;
}

cv::Mat MixChannels(const cv::Mat& radiance, const cv::Matx33f& camera_from_linear) {
  cv::Mat out;
  cv::transform(radiance, out, camera_from_linear);
  return out;
}

}  // namespace relume::calibration::testing
