#include "sim/devices/depth_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>
#include <utility>
#include <vector>

#include "core/error.h"
#include "sim/devices/test_rig.h"

namespace relume::sim {
namespace {

using testing::AnalyticPlane;
using testing::AnalyticScene;
using testing::AnalyticTruth;
using testing::LookingAtWall;
using testing::RigStart;

AnalyticScene WallAt(double distance_m, double tilt_rad = 0.0) {
  AnalyticScene scene;
  AnalyticPlane wall;
  wall.point_in_world = Eigen::Vector3d(distance_m, 0, 0);
  wall.normal_in_world = Eigen::Vector3d(-std::cos(tilt_rad), std::sin(tilt_rad), 0.0);
  scene.planes.push_back(wall);
  return scene;
}

DepthModelOptions Exact() {
  DepthModelOptions options;
  options.noise = false;
  options.disparity_step_px = 0.0;
  options.depth_step_m = 0.0;
  return options;
}

cv::Mat Measure(const AnalyticScene& scene, const PinholeCamera& camera, const DepthModelOptions& options,
                cv::Mat* truth_depth = nullptr) {
  const GroundTruth truth = AnalyticTruth(scene).Render(camera, RigStart());
  if (truth_depth) *truth_depth = truth.depth_m;
  return MeasureDepth(truth.depth_m, truth.normal_in_world, camera, options, 5);
}

int CountFinite(const cv::Mat& depth) {
  int n = 0;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) n += std::isfinite(depth.at<float>(y, x));
  return n;
}

TEST(SimDepthModelTest, SigmaFollowsTheKinectModel) {
  const DepthModelOptions options;
  EXPECT_NEAR(DepthSigma(1.0, 0.0, options), 0.0012 + 0.0019 * 0.36, 1e-12);
  EXPECT_NEAR(DepthSigma(3.5, 0.0, options), 0.0012 + 0.0019 * 3.1 * 3.1, 1e-12);
  const double theta = 1.0;  // 57 degrees: the angle term is now visible
  EXPECT_NEAR(DepthSigma(1.0, theta, options) - DepthSigma(1.0, 0.0, options),
              0.0001 * theta * theta / std::pow(std::numbers::pi / 2 - theta, 2), 1e-12);
}

TEST(SimDepthModelTest, NoiseHasTheModelledSpreadAndNoBias) {
  DepthModelOptions options = Exact();
  options.noise = true;
  const PinholeCamera camera = LookingAtWall(80, 60, 8.0);  // narrow: incidence below 4 degrees
  cv::Mat truth;
  const cv::Mat measured = Measure(WallAt(2.0), camera, options, &truth);
  double sum = 0.0, sum2 = 0.0;
  int n = 0;
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) {
      const double e = measured.at<float>(y, x) - truth.at<float>(y, x);
      ASSERT_TRUE(std::isfinite(e));
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  const double sigma = DepthSigma(2.0, 0.0, options);  // 6.06 mm
  const double mean = sum / n, stddev = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(stddev, sigma, 0.05 * sigma);
  EXPECT_NEAR(mean, 0.0, 4 * sigma / std::sqrt(n));
}

TEST(SimDepthModelTest, DisparityQuantisationStepsGrowWithDepthSquared) {
  DepthModelOptions options = Exact();
  options.disparity_step_px = 1.0 / 8;
  options.depth_step_m = 0.001;
  for (double distance : {0.8, 2.0, 4.0}) {
    const PinholeCamera camera = LookingAtWall(40, 30, 60.0);
    cv::Mat truth;
    const cv::Mat measured = Measure(WallAt(distance, 0.5), camera, options, &truth);
    const double fb = camera.intrinsics.fx * options.projector_baseline_m;
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 40; ++x) {
        const double z = truth.at<float>(y, x), m = measured.at<float>(y, x);
        if (!std::isfinite(m)) continue;
        // Half a disparity step in depth, plus half a millimetre of output rounding.
        // Half a disparity step (exactly, through z = f b / d), plus half a millimetre of output rounding.
        const double half_step = fb / (fb / z - 0.5 * options.disparity_step_px) - z + 0.0005;
        ASSERT_LE(std::abs(m - z), half_step + 1e-6) << "at " << distance << " m";
        ASSERT_NEAR(m * 1000.0, std::round(m * 1000.0), 1e-3) << "whole millimetres";
      }
    }
  }
}

TEST(SimDepthModelTest, HolesAtGrazingAnglesOutOfRangeAndAtDepthEdges) {
  const DepthModelOptions options = Exact();
  const PinholeCamera narrow = LookingAtWall(32, 24, 5.0);
  EXPECT_EQ(CountFinite(Measure(WallAt(2.0, 1.22), narrow, options)), 32 * 24);  // 70 degrees: measured
  EXPECT_EQ(CountFinite(Measure(WallAt(2.0, 1.40), narrow, options)), 0);        // 80 degrees: holes
  EXPECT_EQ(CountFinite(Measure(WallAt(0.3), narrow, options)), 0);              // too near
  EXPECT_EQ(CountFinite(Measure(WallAt(5.0), narrow, options)), 0);              // too far
  // A sphere in front of a wall: a ring of holes along its outline, measured inside and out.
  AnalyticScene scene = WallAt(3.0);
  testing::AnalyticSphere sphere;
  sphere.centre_in_world = Eigen::Vector3d(2.0, 0, 0);
  sphere.radius_m = 0.3;
  scene.spheres.push_back(sphere);
  const PinholeCamera camera = LookingAtWall(64, 48, 40.0);
  cv::Mat truth;
  const cv::Mat measured = Measure(scene, camera, options, &truth);
  const GroundTruth ids = AnalyticTruth(scene).Render(camera, RigStart());
  int edge_holes = 0, edges = 0;
  for (int y = 1; y < 47; ++y) {
    for (int x = 1; x < 63; ++x) {
      const int id = ids.object_id.at<int>(y, x);
      const bool edge = ids.object_id.at<int>(y, x + 1) != id || ids.object_id.at<int>(y, x - 1) != id ||
                        ids.object_id.at<int>(y + 1, x) != id || ids.object_id.at<int>(y - 1, x) != id;
      if (edge) {
        ++edges;
        edge_holes += !std::isfinite(measured.at<float>(y, x));
      }
    }
  }
  EXPECT_GT(edges, 20);
  EXPECT_EQ(edge_holes, edges);
  EXPECT_TRUE(std::isfinite(measured.at<float>(24, 32))) << "the sphere's centre";
  EXPECT_TRUE(std::isfinite(measured.at<float>(2, 2))) << "the wall";
}

TEST(SimDepthModelTest, RegistrationMatchesTheColourCamerasOwnDepth) {
  AnalyticScene scene = testing::WallAndSphereScene();
  const PinholeCamera depth_camera = LookingAtWall(96, 72, 50.0);
  const Eigen::Isometry3d color_from_depth(Eigen::Translation3d(-0.05, 0.0, 0.0));
  PinholeCamera color_camera = depth_camera;
  color_camera.world_from_camera = depth_camera.world_from_camera * color_from_depth.inverse();
  DepthModelOptions options = Exact();
  options.edge_jump_fraction = 1e9;  // no edge holes: compare everywhere
  const cv::Mat depth = Measure(scene, depth_camera, options);
  const cv::Mat registered =
      RegisterDepthToColor(depth, depth_camera.intrinsics, color_camera.intrinsics, color_from_depth);
  const GroundTruth color_truth = AnalyticTruth(scene).Render(color_camera, RigStart());
  int compared = 0, wall = 0;
  double worst = 0.0;
  for (int y = 0; y < 72; ++y) {
    for (int x = 0; x < 96; ++x) {
      if (color_truth.object_id.at<int>(y, x) != 0) continue;  // the fronto-parallel wall
      ++wall;
      const float r = registered.at<float>(y, x);
      if (!std::isfinite(r)) continue;
      ++compared;
      worst = std::max(worst, std::abs(r - static_cast<double>(color_truth.depth_m.at<float>(y, x))));
    }
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(compared, 0.9 * wall);
  // The sphere moved in the image by about f b / z pixels against the unregistered depth.
  // The colour camera sits 5 cm to the right, so near things move left: by f b / z pixels.
  double mean_z = 0.0;
  auto sphere_column = [&mean_z](const cv::Mat& d) {
    double sum = 0.0, z_sum = 0.0;
    int n = 0;
    for (int x = 0; x < d.cols; ++x) {
      const float z = d.at<float>(36, x);
      if (std::isfinite(z) && z < 2.5) {
        sum += x;
        z_sum += z;
        ++n;
      }
    }
    mean_z = z_sum / n;
    return sum / n;
  };
  const double column_before = sphere_column(depth);
  const double expected_shift = -depth_camera.intrinsics.fx * 0.05 / mean_z;
  EXPECT_NEAR(sphere_column(registered) - column_before, expected_shift, 0.5);
}

TEST(SimDepthModelTest, InterpolatedRegistrationFollowsCurvedSurfacesWhereNearestSteps) {
  // As on a Kinect: depth 58 deg, colour 62.5 deg wide, 2.5 cm apart; a sphere fills much of
  // the view. The colour camera's own rendered depth is the truth.
  AnalyticScene scene = testing::WallAndSphereScene();
  const PinholeCamera depth_camera = LookingAtWall(160, 120, 58.0);
  const Eigen::Isometry3d color_from_depth(Eigen::Translation3d(-0.025, 0.0, 0.0));
  PinholeCamera color_camera = LookingAtWall(160, 120, 62.5);
  color_camera.world_from_camera = depth_camera.world_from_camera * color_from_depth.inverse();
  const DepthModelOptions options = Exact();
  const cv::Mat depth = Measure(scene, depth_camera, options);
  const GroundTruth color_truth = AnalyticTruth(scene).Render(color_camera, RigStart());
  auto errors = [&](Registration method) {
    const cv::Mat registered = RegisterDepthToColor(depth, depth_camera.intrinsics, color_camera.intrinsics,
                                                    color_from_depth, method, options.edge_jump_fraction);
    std::vector<double> e;
    int sphere = 0;
    for (int y = 1; y + 1 < registered.rows; ++y) {
      for (int x = 1; x + 1 < registered.cols; ++x) {
        const cv::Mat& id = color_truth.object_id;
        const int here = id.at<int>(y, x);
        if (here != id.at<int>(y, x - 1) || here != id.at<int>(y, x + 1) || here != id.at<int>(y - 1, x) ||
            here != id.at<int>(y + 1, x) || here != 1) {
          continue;  // the sphere's inside, away from its silhouette
        }
        ++sphere;
        const double r = registered.at<float>(y, x);
        if (std::isfinite(r)) e.push_back(std::abs(r - color_truth.depth_m.at<float>(y, x)));
      }
    }
    std::sort(e.begin(), e.end());
    EXPECT_GT(e.size(), 0.95 * sphere) << "holes";
    return std::pair{e[e.size() / 2], e[e.size() * 9 / 10]};
  };
  const auto [nearest_median, nearest_p90] = errors(Registration::kNearest);
  const auto [interpolated_median, interpolated_p90] = errors(Registration::kInterpolated);
  std::cout << "registration error on the sphere (m): nearest median " << nearest_median << " p90 " << nearest_p90
            << "; interpolated median " << interpolated_median << " p90 " << interpolated_p90 << "\n";
  EXPECT_GT(nearest_median, 5e-4);  // the half-pixel offsets and the shared pixels
  // Bilinear interpolation's own error: (12 mm pixels)^2 / 8 over a 0.45 m radius, ~4e-5 m.
  EXPECT_LT(interpolated_median, 1.5e-4);
  EXPECT_LT(interpolated_median, nearest_median / 10);
  EXPECT_LT(interpolated_p90, nearest_p90 / 4);
}

TEST(SimDepthModelTest, InvalidOptionsAndSizesAreRejected) {
  DepthModelOptions options;
  options.max_range_m = 0.1;
  EXPECT_FALSE(options.IsValid(nullptr));
  const PinholeCamera camera = LookingAtWall(8, 6);
  EXPECT_THROW(MeasureDepth(cv::Mat(5, 8, CV_32FC1), cv::Mat(6, 8, CV_32FC3), camera, DepthModelOptions{}, 1),
               InvalidArgumentError);
}

}  // namespace
}  // namespace relume::sim
