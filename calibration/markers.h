// ArUco markers (OpenCV's aruco module): the predefined dictionaries by name, detection with
// sub-pixel corners, printing, and markers whose corners were surveyed in the site frame as
// ground control points for camera_pose.h, so that a camera's pose comes from one frame without
// marking pixels by hand.
//
// Conventions: a marker's corners in the order OpenCV detects them, which is the printed
// marker's top-left, top-right, bottom-right, bottom-left (DrawMarker's image: (0, 0), (n, 0),
// (n, n), (0, n)). Pixels in core/pinhole.h's continuous coordinates (pixel centres at u + 0.5):
// OpenCV's corners, with centres at integers, are shifted by +0.5.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calibration/camera_pose.h"
#include "core/site.h"

namespace relume::calibration {

// relume's names of OpenCV's predefined dictionaries: "4x4_50" .. "7x7_1000", "original",
// "apriltag_16h5" .. "apriltag_36h11".
std::vector<std::string> ArucoDictionaryNames();
// OpenCV's cv::aruco::PREDEFINED_DICTIONARY_NAME of `name`; InvalidArgumentError listing the names.
int ArucoDictionaryId(const std::string& name);

struct MarkerDetection {
  int id = -1;
  std::array<Eigen::Vector2d, 4> corners_px;
};

// The markers of `dictionary` in `image` (8-bit grey or RGB), corners refined to sub-pixel.
std::vector<MarkerDetection> DetectMarkers(const cv::Mat& image, const std::string& dictionary);

// Marker `id` as an 8-bit grey image of `pixels` x `pixels` (a one-bit black border; a multiple
// of the dictionary's bits + 2 gives whole pixels per bit), to print.
cv::Mat DrawMarker(const std::string& dictionary, int id, int pixels);

struct SurveyedMarker {
  int id = -1;
  std::array<Eigen::Vector3d, 4> corners_enu_m;  // in the order above
};

// A marker file: CSV with a header, one surveyed corner per line: `id,corner,a,b,c`, corner 0..3
// in the order above, (a, b, c) in `frame` (SurveyFrame). Every marker needs its four corners,
// once each. ConfigError naming the line or the marker.
std::vector<SurveyedMarker> LoadMarkerFile(const std::string& path, const std::string& frame, const Site& site,
                                           int zone = 0);

// The detected corners of surveyed markers as ground control points named "marker ID corner C".
// Ids detected but not surveyed go to `unsurveyed` (may be null): another dictionary or a
// marker left out of the file.
std::vector<GroundControlPoint> MarkerControlPoints(const std::vector<MarkerDetection>& detections,
                                                    const std::vector<SurveyedMarker>& markers,
                                                    std::vector<int>* unsurveyed = nullptr);

}  // namespace relume::calibration
