#include "sim/world/truth_files.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/color.h"
#include "core/error.h"

namespace relume::sim {

namespace {

cv::Mat ToBgr(const cv::Mat& rgb) {
  if (rgb.channels() != 3) return rgb;
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

void Write(const std::filesystem::path& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image);
  } catch (const cv::Exception& e) {
    throw IoError(path.string(), std::string("cannot write the image: ") + e.what());
  }
  if (!ok) throw IoError(path.string(), "cannot write the image (is the folder writable?)");
}

// The value at `fraction` of the sorted finite, positive samples (0 when there are none).
double Percentile(const cv::Mat& image, double fraction) {
  std::vector<float> values;
  const cv::Mat flat = image.reshape(1, 1);
  for (int i = 0; i < flat.cols; ++i) {
    const float v = flat.at<float>(0, i);
    if (std::isfinite(v) && v > 0.0f) values.push_back(v);
  }
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(fraction * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

// Linear float (1 or 3 channels) -> 8-bit: clip(v * scale + offset), optionally sRGB-encoded.
cv::Mat Preview(const cv::Mat& image, double scale, double offset, bool srgb) {
  const int channels = image.channels();
  cv::Mat out(image.rows, image.cols, CV_8UC(channels));
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    auto* o = out.ptr<unsigned char>(y);
    for (int i = 0; i < image.cols * channels; ++i) {
      double v = std::isfinite(in[i]) ? std::clamp(in[i] * scale + offset, 0.0, 1.0) : 0.0;
      if (srgb) v = SrgbEncode(v);
      o[i] = static_cast<unsigned char>(std::lround(v * 255.0));
    }
  }
  return out;
}

double InverseOrOne(double value) {
  return value > 0.0 ? 1.0 / value : 1.0;
}

}  // namespace

void WriteGroundTruth(const GroundTruth& truth, const std::string& folder) {
  const std::filesystem::path dir(folder);
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw IoError(dir.string(), "cannot create the output folder: " + error.message());
  // OpenCV 4 enables its EXR codec only when this is set before the codec is first used.
  setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);

  Write(dir / "radiance.exr", ToBgr(truth.radiance.pixels));
  Write(dir / "depth.exr", truth.depth_m);
  Write(dir / "normals.exr", ToBgr(truth.normal_in_world));
  Write(dir / "albedo.exr", ToBgr(truth.albedo));
  Write(dir / "sun_visibility.exr", truth.sun_visibility);
  Write(dir / "irradiance.exr", ToBgr(truth.irradiance));

  Write(dir / "radiance.png",
        ToBgr(Preview(truth.radiance.pixels, InverseOrOne(Percentile(truth.radiance.pixels, 0.99)), 0.0, true)));
  Write(dir / "depth.png", Preview(truth.depth_m, InverseOrOne(Percentile(truth.depth_m, 1.0)), 0.0, false));
  Write(dir / "normals.png", ToBgr(Preview(truth.normal_in_world, 0.5, 0.5, false)));
  Write(dir / "albedo.png", ToBgr(Preview(truth.albedo, 1.0, 0.0, true)));
  Write(dir / "sun_visibility.png", Preview(truth.sun_visibility, 1.0, 0.0, false));
  Write(dir / "irradiance.png",
        ToBgr(Preview(truth.irradiance, InverseOrOne(Percentile(truth.irradiance, 0.99)), 0.0, false)));
}

}  // namespace relume::sim
