// Test support shared by this folder's tests: a manual clock, the wall-and-sphere analytic
// scene, and cameras looking at it.
#pragma once

#include <memory>
#include <numbers>

#include "core/clock.h"
#include "core/time.h"
#include "sim/devices/analytic_truth.h"

namespace relume::sim::testing {

inline UtcTime RigStart() {
  return ParseIso8601("2026-06-21T10:00:00Z").utc;
}

struct TestRig {
  std::shared_ptr<ManualClock> clock = std::make_shared<ManualClock>(RigStart());
  std::shared_ptr<AnalyticTruth> truth;
  explicit TestRig(AnalyticScene scene = WallAndSphereScene()) {
    scene.reference_time = RigStart();
    truth = std::make_shared<AnalyticTruth>(std::move(scene));
  }
};

// A camera at the origin looking along +x (at the wall of WallAndSphereScene).
inline PinholeCamera LookingAtWall(int width, int height, double horizontal_fov_deg = 50.0) {
  return PinholeCamera::LookAt(
      PinholeIntrinsics::FromHorizontalFov(width, height, horizontal_fov_deg * std::numbers::pi / 180.0),
      Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
}

}  // namespace relume::sim::testing
