#include "calibration/markers.h"

#include <cmath>
#include <fstream>
#include <map>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "core/input_file.h"

namespace relume::calibration {
namespace {

struct NamedDictionary {
  const char* name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
};

constexpr NamedDictionary kDictionaries[] = {
    {"4x4_50", cv::aruco::DICT_4X4_50},
    {"4x4_100", cv::aruco::DICT_4X4_100},
    {"4x4_250", cv::aruco::DICT_4X4_250},
    {"4x4_1000", cv::aruco::DICT_4X4_1000},
    {"5x5_50", cv::aruco::DICT_5X5_50},
    {"5x5_100", cv::aruco::DICT_5X5_100},
    {"5x5_250", cv::aruco::DICT_5X5_250},
    {"5x5_1000", cv::aruco::DICT_5X5_1000},
    {"6x6_50", cv::aruco::DICT_6X6_50},
    {"6x6_100", cv::aruco::DICT_6X6_100},
    {"6x6_250", cv::aruco::DICT_6X6_250},
    {"6x6_1000", cv::aruco::DICT_6X6_1000},
    {"7x7_50", cv::aruco::DICT_7X7_50},
    {"7x7_100", cv::aruco::DICT_7X7_100},
    {"7x7_250", cv::aruco::DICT_7X7_250},
    {"7x7_1000", cv::aruco::DICT_7X7_1000},
    {"original", cv::aruco::DICT_ARUCO_ORIGINAL},
    {"apriltag_16h5", cv::aruco::DICT_APRILTAG_16h5},
    {"apriltag_25h9", cv::aruco::DICT_APRILTAG_25h9},
    {"apriltag_36h10", cv::aruco::DICT_APRILTAG_36h10},
    {"apriltag_36h11", cv::aruco::DICT_APRILTAG_36h11},
};

cv::Mat Grey(const cv::Mat& image) {
  if (image.empty()) throw InvalidArgumentError("marker detection: the image is empty");
  if (image.depth() != CV_8U) throw InvalidArgumentError("marker detection takes 8-bit images");
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_RGBA2GRAY : cv::COLOR_RGB2GRAY);
  return grey;
}

}  // namespace

std::vector<std::string> ArucoDictionaryNames() {
  std::vector<std::string> names;
  for (const NamedDictionary& d : kDictionaries) names.emplace_back(d.name);
  return names;
}

int ArucoDictionaryId(const std::string& name) {
  std::string all;
  for (const NamedDictionary& d : kDictionaries) {
    if (name == d.name) return static_cast<int>(d.id);
    all += (all.empty() ? "" : ", ") + std::string(d.name);
  }
  throw InvalidArgumentError("no ArUco dictionary named '" + name + "' (relume knows " + all + ")");
}

std::vector<MarkerDetection> DetectMarkers(const cv::Mat& image, const std::string& dictionary) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(ArucoDictionaryId(dictionary));
  cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(Grey(image), dict, corners, ids, params);
  std::vector<MarkerDetection> out;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    MarkerDetection d;
    d.id = ids[i];
    for (int c = 0; c < 4; ++c) {
      const cv::Point2f& p = corners[i][static_cast<std::size_t>(c)];
      d.corners_px[static_cast<std::size_t>(c)] = Eigen::Vector2d(p.x + 0.5, p.y + 0.5);
    }
    out.push_back(d);
  }
  return out;
}

cv::Mat DrawMarker(const std::string& dictionary, int id, int pixels) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(ArucoDictionaryId(dictionary));
  if (id < 0 || id >= dict->bytesList.rows) {
    throw InvalidArgumentError("marker id " + std::to_string(id) + " is not in dictionary " + dictionary + " (0.." +
                               std::to_string(dict->bytesList.rows - 1) + ")");
  }
  if (pixels < dict->markerSize + 2) {
    throw InvalidArgumentError("a " + dictionary + " marker needs at least " + std::to_string(dict->markerSize + 2) +
                               " pixels a side");
  }
  cv::Mat image;
  cv::aruco::drawMarker(dict, id, pixels, image, 1);
  return image;
}

std::vector<SurveyedMarker> LoadMarkerFile(const std::string& path, const std::string& frame, const Site& site,
                                           int zone) {
  const SurveyFrame survey(frame, site, zone);
  std::ifstream in = OpenInputFile(path);
  std::map<int, SurveyedMarker> markers;
  std::map<int, std::array<int, 4>> line_of;  // per marker and corner, the line that gave it (0: none)
  std::string line;
  int number = 0;
  bool any = false;
  while (std::getline(in, line)) {
    ++number;
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) cells.push_back(cell);
    double n[5];
    bool numeric = cells.size() == 5;
    for (std::size_t c = 0; numeric && c < 5; ++c) numeric = ParseCsvNumber(cells[c], &n[c]);
    numeric = numeric && n[0] == std::floor(n[0]) && n[1] == std::floor(n[1]) && std::abs(n[0]) < 1e9;
    const int id = numeric ? static_cast<int>(n[0]) : 0;
    const int corner = numeric && std::abs(n[1]) < 1e9 ? static_cast<int>(n[1]) : -1;
    const double* v = n + 2;
    if (!numeric) {
      if (!any && number == 1) continue;  // the header
      throw ConfigError(path, number, "marker", "expected id,corner,a,b,c with numbers (a, b, c in " + frame + ")");
    }
    any = true;
    if (id < 0) throw ConfigError(path, number, "marker", "marker id " + std::to_string(id) + " is negative");
    if (corner < 0 || corner > 3) {
      throw ConfigError(path, number, "marker",
                        "corner " + std::to_string(corner) +
                            " is not 0..3 (top-left, top-right, bottom-right, bottom-left as printed)");
    }
    std::array<int, 4>& lines = line_of.try_emplace(id, std::array<int, 4>{0, 0, 0, 0}).first->second;
    if (lines[static_cast<std::size_t>(corner)] != 0) {
      throw ConfigError(path, number, "marker",
                        "marker " + std::to_string(id) + " corner " + std::to_string(corner) + " is also on line " +
                            std::to_string(lines[static_cast<std::size_t>(corner)]));
    }
    lines[static_cast<std::size_t>(corner)] = number;
    SurveyedMarker& m = markers[id];
    m.id = id;
    try {
      m.corners_enu_m[static_cast<std::size_t>(corner)] = survey.ToEnu(Eigen::Vector3d(v[0], v[1], v[2]));
    } catch (const InvalidArgumentError& e) {
      throw ConfigError(path, number, "marker", e.what());
    }
  }
  if (markers.empty()) throw ConfigError(path, number, "marker", "no surveyed marker corners in the file");
  std::vector<SurveyedMarker> out;
  for (const auto& [id, m] : markers) {
    for (int c = 0; c < 4; ++c) {
      if (line_of[id][static_cast<std::size_t>(c)] == 0) {
        throw ConfigError(path, number, "marker",
                          "marker " + std::to_string(id) + " has no corner " + std::to_string(c) +
                              ": give all four (top-left, top-right, bottom-right, bottom-left as printed)");
      }
    }
    out.push_back(m);
  }
  return out;
}

std::vector<GroundControlPoint> MarkerControlPoints(const std::vector<MarkerDetection>& detections,
                                                    const std::vector<SurveyedMarker>& markers,
                                                    std::vector<int>* unsurveyed) {
  std::map<int, const SurveyedMarker*> by_id;
  for (const SurveyedMarker& m : markers) by_id[m.id] = &m;
  std::vector<GroundControlPoint> points;
  for (const MarkerDetection& d : detections) {
    const auto it = by_id.find(d.id);
    if (it == by_id.end()) {
      if (unsurveyed != nullptr) unsurveyed->push_back(d.id);
      continue;
    }
    for (std::size_t c = 0; c < 4; ++c) {
      GroundControlPoint p;
      p.name = "marker " + std::to_string(d.id) + " corner " + std::to_string(c);
      p.pixel = d.corners_px[c];
      p.enu_m = it->second->corners_enu_m[c];
      points.push_back(p);
    }
  }
  return points;
}

}  // namespace relume::calibration
