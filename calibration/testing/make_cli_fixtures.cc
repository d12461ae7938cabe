// Writes the synthetic images the CLI tests run on (label cli): a 5-frame gamma bracket with
// its exposure times, a photographed ColorChecker (8-bit sRGB-encoded and linear EXR) and a
// corners file. Usage: relume_calibration_fixtures OUTPUT_DIR
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core.hpp>

#include "calibration/image_file.h"
#include "calibration/testing/synthetic_bracket.h"
#include "calibration/testing/synthetic_chart.h"
#include "core/color.h"
#include "core/error.h"

int main(int argc, char** argv) {
  using namespace relume;
  using namespace relume::calibration;
  if (argc != 3) {
    std::cerr << "usage: relume_calibration_fixtures OUTPUT_DIR CHART_REFERENCE_YAML\n";
    return 2;
  }
  try {
    const std::string dir = argv[1];
    std::filesystem::create_directories(dir);
    testing::SceneOptions scene;
    scene.width = 240;
    scene.height = 180;
    scene.dynamic_range = 1e4;
    const cv::Mat radiance = testing::MakeHdrRadiance(scene);
    const std::vector<double> times = testing::BracketExposures(5, 2.0, 18.0);
    testing::NoiseOptions noise;
    noise.shot_noise = 1e-5;
    noise.read_noise = 2e-4;
    const auto frames =
        testing::RenderBracket(radiance, times, testing::SyntheticResponse{testing::ResponseShape::kGamma}, noise);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      SaveImage(frames[i].pixels, dir + "/bracket_" + std::to_string(i) + ".png");
    }
    std::ofstream(dir + "/exposures.txt")
        << times[0] << "," << times[1] << "," << times[2] << "," << times[3] << "," << times[4] << "\n";
    const ColorCheckerReference reference = LoadColorCheckerReference(argv[2]);
    testing::ChartSceneOptions chart;
    chart.light = cv::Vec3d(1.1, 1.0, 0.8);
    const cv::Mat linear = testing::RenderChartRadiance(reference, chart) * 0.9;
    cv::Mat encoded(linear.size(), CV_8UC3);
    for (int y = 0; y < linear.rows; ++y) {
      for (int x = 0; x < linear.cols; ++x) {
        for (int c = 0; c < 3; ++c) {
          encoded.at<cv::Vec3b>(y, x)[c] = cv::saturate_cast<std::uint8_t>(
              255.0 * SrgbEncode(std::clamp(static_cast<double>(linear.at<cv::Vec3f>(y, x)[c]), 0.0, 1.0)));
        }
      }
    }
    SaveImage(encoded, dir + "/chart.png");
    RadianceImage exr;
    exr.pixels = linear;
    SaveRadianceExr(exr, dir + "/chart_linear.exr");
    std::ofstream yaml(dir + "/corners.yaml");
    yaml << "corners:\n";
    for (const auto& p : chart.corners) yaml << "  - [" << p.x << ", " << p.y << "]\n";
    std::cout << "wrote fixtures to " << dir << "\n";
  } catch (const relume::Error& e) {
    std::cerr << "relume_calibration_fixtures: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
