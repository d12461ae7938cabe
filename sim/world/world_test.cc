#include "sim/world/world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <thread>

#include "core/error.h"
#include "core/frames.h"
#include "sim/world/scene_yaml.h"

namespace relume::sim {
namespace {

constexpr double kPi = std::numbers::pi;

// A scene with a fixed sun direction (site and time matter only where a test says so).
Scene BaseScene() {
  Scene scene;
  scene.name = "test";
  scene.site = Site::FromDegrees(37.97153, 23.72644, 190.0);
  scene.time = ParseIso8601("2026-06-21T12:00:00Z").utc;
  scene.sun.irradiance_w_m2 = {1000.0, 980.0, 950.0};
  scene.sky = Sky::Black();
  scene.render.threads = 2;
  return scene;
}

SceneObject Ground(double half_size_m, const Eigen::Vector3d& albedo) {
  SceneObject ground;
  ground.name = "ground";
  ground.shape = SceneObject::Shape::kPlane;
  ground.albedo = albedo;
  ground.mesh = MakeQuad({-half_size_m, -half_size_m, 0.0}, {2 * half_size_m, 0, 0}, {0, 2 * half_size_m, 0});
  return ground;
}

Eigen::Vector3d Direction(double azimuth_deg, double elevation_deg) {
  return EnuDirectionFromAzimuthElevation(DegToRad(azimuth_deg), DegToRad(elevation_deg));
}

PinholeCamera DownCamera(const Eigen::Vector3d& eye, int size, double hfov_deg) {
  return PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(size, size, DegToRad(hfov_deg)), eye,
                               eye - Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitY());
}

Eigen::Vector3d Rgb(const cv::Mat& image, int u, int v) {
  const cv::Vec3f p = image.at<cv::Vec3f>(v, u);
  return {p[0], p[1], p[2]};
}

TEST(WorldTest, SunLitPlaneRadianceIsAlbedoTimesIrradianceOverPi) {
  Scene scene = BaseScene();
  scene.sun.direction_in_enu = Direction(200.0, 50.0);
  const Eigen::Vector3d albedo(0.2, 0.5, 0.8);
  scene.objects.push_back(Ground(50.0, albedo));
  const World world(scene);
  const GroundTruth truth = world.Render(DownCamera({0, 0, 5}, 32, 60.0));
  const Eigen::Vector3d irradiance = scene.sun.irradiance_w_m2 * std::sin(DegToRad(50.0));
  for (int v = 0; v < 32; ++v) {
    for (int u = 0; u < 32; ++u) {
      ASSERT_EQ(truth.object_id.at<int>(v, u), 0);
      EXPECT_FLOAT_EQ(truth.sun_visibility.at<float>(v, u), 1.0f);
      const Eigen::Vector3d radiance = Rgb(truth.radiance.pixels, u, v);
      const Eigen::Vector3d expected = albedo.cwiseProduct(irradiance) / kPi;
      // The disk-averaged cosine differs from the centre's by < 1e-5 relative.
      EXPECT_LT(((radiance - expected).array() / expected.array()).abs().maxCoeff(), 2e-5) << u << "," << v;
      EXPECT_LT((Rgb(truth.irradiance, u, v) - irradiance).norm() / irradiance.norm(), 2e-5);
      EXPECT_LT((Rgb(truth.albedo, u, v) - albedo).norm(), 1e-6);
    }
  }
}

TEST(WorldTest, SunPlusUniformSkyOnAnUnoccludedPlane) {
  Scene scene = BaseScene();
  scene.sun.direction_in_enu = Direction(90.0, 30.0);
  const Eigen::Vector3d sky_radiance(20.0, 30.0, 45.0);
  scene.sky = Sky::Uniform(sky_radiance);
  const Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.4);
  scene.objects.push_back(Ground(1000.0, albedo));
  scene.render.sky_samples = 17;
  const World world(scene);
  const GroundTruth truth = world.Render(DownCamera({3, -2, 2}, 16, 40.0));
  const Eigen::Vector3d irradiance = scene.sun.irradiance_w_m2 * 0.5 + kPi * sky_radiance;  // E_sky = pi L
  for (int v = 0; v < 16; ++v) {
    for (int u = 0; u < 16; ++u) {
      const Eigen::Vector3d e = Rgb(truth.irradiance, u, v);
      EXPECT_LT(((e - irradiance).array() / irradiance.array()).abs().maxCoeff(), 2e-5);
      const Eigen::Vector3d expected = albedo.cwiseProduct(irradiance) / kPi;
      EXPECT_LT(((Rgb(truth.radiance.pixels, u, v) - expected).array() / expected.array()).abs().maxCoeff(), 2e-5);
    }
  }
}

TEST(WorldTest, GradientSkyIrradianceMatchesTheAnalyticIntegral) {
  Scene scene = BaseScene();
  scene.sun.enabled = false;
  scene.sky = Sky::Gradient({10.0, 20.0, 40.0}, {40.0, 40.0, 40.0});
  scene.objects.push_back(Ground(1000.0, Eigen::Vector3d::Constant(0.5)));
  scene.render.sky_samples = 256;
  const World world(scene);
  const GroundTruth truth = world.Render(DownCamera({0, 0, 2}, 4, 40.0));
  const Eigen::Vector3d expected = scene.sky.HorizontalIrradiance();
  const Eigen::Vector3d e = Rgb(truth.irradiance, 2, 2);
  EXPECT_LT(((e - expected).array() / expected.array()).abs().maxCoeff(), 1e-3) << e.transpose();
  EXPECT_FLOAT_EQ(truth.sun_visibility.at<float>(2, 2), 0.0f);
}

TEST(WorldTest, SphereShadingDepthAndNormalsMatchAnalyticAnswers) {
  Scene scene = BaseScene();
  const Eigen::Vector3d sun = Direction(135.0, 40.0);
  scene.sun.direction_in_enu = sun;
  scene.sun.angular_diameter_rad = 0.0;
  scene.render.sun_samples = 1;
  SceneObject sphere;
  sphere.name = "ball";
  sphere.shape = SceneObject::Shape::kSphere;
  sphere.sphere_center = {0.3, -0.2, 1.0};
  sphere.sphere_radius_m = 0.5;
  sphere.albedo = {0.7, 0.6, 0.5};
  scene.objects.push_back(sphere);
  const World world(scene);
  const PinholeCamera camera = PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(64, 48, DegToRad(40.0)),
                                                     {2.5, -3.0, 1.8}, sphere.sphere_center);
  const GroundTruth truth = world.Render(camera);
  int hits = 0, lit = 0;
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) {
      // Analytic ray-sphere intersection in double precision.
      const Eigen::Vector3d d = camera.world_from_camera.linear() * camera.intrinsics.Unproject({u + 0.5, v + 0.5});
      const Eigen::Vector3d o = camera.world_from_camera.translation() - sphere.sphere_center;
      const double a = d.squaredNorm(), b = 2 * o.dot(d), c = o.squaredNorm() - 0.25;
      const double disc = b * b - 4 * a * c;
      const double margin = 1e-3 * b * b;  // skip grazing rays, where float and double may disagree
      if (std::abs(disc) < margin) continue;
      if (disc < 0) {
        EXPECT_EQ(truth.object_id.at<int>(v, u), -1);
        EXPECT_TRUE(std::isnan(truth.depth_m.at<float>(v, u)));
        continue;
      }
      ++hits;
      const double t = (-b - std::sqrt(disc)) / (2 * a);  // = depth, since d has camera z = 1
      const Eigen::Vector3d n = (o + t * d).normalized();
      ASSERT_EQ(truth.object_id.at<int>(v, u), 0);
      EXPECT_NEAR(truth.depth_m.at<float>(v, u), t, 2e-5 * t);
      EXPECT_LT((Rgb(truth.normal_in_world, u, v) - n).norm(), 1e-4);
      const double cosine = n.dot(sun);
      const Eigen::Vector3d e = Rgb(truth.irradiance, u, v);
      if (cosine > 0.01) {
        ++lit;
        EXPECT_NEAR(e.x(), 1000.0 * cosine, 0.2) << "cos " << cosine;
      } else if (cosine < -0.01) {
        EXPECT_EQ(e.x(), 0.0);
      }
    }
  }
  EXPECT_GT(hits, 300);
  EXPECT_GT(lit, 100);
}

TEST(WorldTest, TiltedCameraDepthAndNormalsOnAPlane) {
  Scene scene = BaseScene();
  scene.sun.direction_in_enu = Direction(0.0, 60.0);
  scene.objects.push_back(Ground(100.0, Eigen::Vector3d::Constant(0.3)));
  const World world(scene);
  const PinholeCamera camera = PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(40, 30, DegToRad(50.0)),
                                                     {-1.0, -4.0, 2.0}, {0.5, 0.0, 0.0});
  const GroundTruth truth = world.Render(camera);
  for (int v = 0; v < 30; ++v) {
    for (int u = 0; u < 40; ++u) {
      const Eigen::Vector3d d = camera.world_from_camera.linear() * camera.intrinsics.Unproject({u + 0.5, v + 0.5});
      const double depth = -2.0 / d.z();
      EXPECT_NEAR(truth.depth_m.at<float>(v, u), depth, 1e-5 * depth);
      EXPECT_LT((Rgb(truth.normal_in_world, u, v) - Eigen::Vector3d::UnitZ()).norm(), 1e-6);
    }
  }
}

TEST(WorldTest, NormalsFaceTheCameraFromBelowAPlane) {
  Scene scene = BaseScene();
  scene.sun.direction_in_enu = Direction(0.0, 60.0);
  scene.objects.push_back(Ground(10.0, Eigen::Vector3d::Constant(0.3)));
  const World world(scene);
  const PinholeCamera camera = PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(8, 8, DegToRad(30.0)),
                                                     {0, 0, -2}, {0, 0, 0}, Eigen::Vector3d::UnitY());
  const GroundTruth truth = world.Render(camera);
  EXPECT_LT((Rgb(truth.normal_in_world, 4, 4) + Eigen::Vector3d::UnitZ()).norm(), 1e-6);
  // The underside does not see the sun above.
  EXPECT_EQ(truth.sun_visibility.at<float>(4, 4), 0.0f);
  EXPECT_EQ(Rgb(truth.irradiance, 4, 4).norm(), 0.0);
}

// Convex hull (monotone chain) and point-in-polygon distance, for the shadow test.
std::vector<Eigen::Vector2d> ConvexHull(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(),
            [](const auto& a, const auto& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Eigen::Vector2d> hull(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], p[i - 1]) <= 0) --k;
    hull[k++] = p[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}
// Signed distance to a counter-clockwise convex polygon's boundary: negative inside.
double SignedDistance(const std::vector<Eigen::Vector2d>& hull, const Eigen::Vector2d& q) {
  double inside = -1e300, outside = 1e300;
  bool is_inside = true;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2d a = hull[i], b = hull[(i + 1) % hull.size()];
    const Eigen::Vector2d edge = b - a;
    const double side = (edge.x() * (q - a).y() - edge.y() * (q - a).x()) / edge.norm();
    if (side < 0) is_inside = false;
    inside = std::max(inside, -side);
    const double s = std::clamp((q - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
    outside = std::min(outside, (a + s * edge - q).norm());
  }
  return is_inside ? inside : outside;
}

TEST(WorldTest, BoxShadowFallsWhereTheCornersProjectAlongTheSun) {
  Scene scene = BaseScene();
  const Eigen::Vector3d sun = Direction(230.0, 35.0);
  scene.sun.direction_in_enu = sun;
  scene.objects.push_back(Ground(100.0, Eigen::Vector3d::Constant(0.3)));
  SceneObject box;
  box.name = "box";
  box.shape = SceneObject::Shape::kBox;
  box.mesh = MakeBox({0, 0, 1.0}, {2.0, 1.0, 2.0}, DegToRad(20.0));
  scene.objects.push_back(box);
  const World world(scene);
  const PinholeCamera camera = DownCamera({2.0, 2.0, 30.0}, 128, 30.0);
  const GroundTruth truth = world.Render(camera);
  // The shadow on the ground: the hull of the box's corners projected along -sun onto z = 0.
  std::vector<Eigen::Vector2d> projected;
  for (const Eigen::Vector3d& corner : box.mesh.vertices) {
    const Eigen::Vector3d p = corner - sun * (corner.z() / sun.z());
    projected.emplace_back(p.x(), p.y());
  }
  const std::vector<Eigen::Vector2d> hull = ConvexHull(projected);
  const double pixel_m = 30.0 * 2 * std::tan(DegToRad(15.0)) / 128;
  const double penumbra_m = (2.0 / sun.z()) * 0.00925 / sun.z();  // widest: from the top edge
  int shadowed = 0, checked = 0;
  for (int v = 0; v < 128; ++v) {
    for (int u = 0; u < 128; ++u) {
      if (truth.object_id.at<int>(v, u) != 0) continue;
      const Eigen::Vector3d d = camera.world_from_camera.linear() * camera.intrinsics.Unproject({u + 0.5, v + 0.5});
      const Eigen::Vector3d p = camera.world_from_camera.translation() + truth.depth_m.at<float>(v, u) * d;
      const double distance = SignedDistance(hull, {p.x(), p.y()});
      if (std::abs(distance) < penumbra_m + pixel_m) continue;
      ++checked;
      const float visibility = truth.sun_visibility.at<float>(v, u);
      if (distance < 0) {
        ++shadowed;
        EXPECT_EQ(visibility, 0.0f) << "inside the projected shadow at " << p.transpose();
      } else {
        EXPECT_EQ(visibility, 1.0f) << "outside the projected shadow at " << p.transpose();
      }
    }
  }
  EXPECT_GT(shadowed, 150);
  EXPECT_GT(checked, 8000);
}

// The fraction of a disk of unit radius above a line at signed offset d (d = -1: all, 1: none).
double DiskFractionAbove(double d) {
  d = std::clamp(d, -1.0, 1.0);
  return (std::acos(d) - d * std::sqrt(1.0 - d * d)) / kPi;
}

TEST(WorldTest, PenumbraWidthIsOccluderDistanceTimesTheSunsDiameter) {
  // A wall along y at x = 0 with its top edge at H; the sun due west at elevation e, so the
  // edge's shadow lies on the ground at x = H / tan e, and the penumbra's full width on the
  // ground is (H / sin e) * 0.00925 rad / sin e.
  Scene scene = BaseScene();
  const double e = DegToRad(40.0), height_m = 10.0;
  scene.sun.direction_in_enu = Eigen::Vector3d(-std::cos(e), 0.0, std::sin(e));
  scene.render.sun_samples = 256;
  scene.objects.push_back(Ground(200.0, Eigen::Vector3d::Constant(0.3)));
  SceneObject wall;
  wall.name = "wall";
  wall.shape = SceneObject::Shape::kPlane;
  wall.mesh = MakeQuad({0, -100, 0}, {0, 200, 0}, {0, 0, height_m});
  scene.objects.push_back(wall);
  const World world(scene);
  const double edge_x = height_m / std::tan(e);
  const double width_m = (height_m / std::sin(e)) * DegToRad(0.53) / std::sin(e);
  // One row of 1 mm pixels across the edge.
  PinholeCamera camera = DownCamera({edge_x, 0.0, 1.0}, 400, 2 * RadToDeg(std::atan(0.2)));
  camera.intrinsics.height = 1;
  camera.intrinsics.cy = 0.5;
  const GroundTruth truth = world.Render(camera);
  double first_lit = NAN, first_full = NAN, worst = 0.0;
  for (int u = 0; u < 400; ++u) {
    const double x = edge_x + (u + 0.5 - 200.0) / 1000.0;
    const float visibility = truth.sun_visibility.at<float>(0, u);
    if (std::isnan(first_lit) && visibility > 0.0f) first_lit = x;
    if (std::isnan(first_full) && visibility >= 1.0f) first_full = x;
    // The analytic visible fraction: the edge's elevation seen from x against the disk.
    const double edge_elevation = std::atan2(height_m, x);
    const double offset = (edge_elevation - e) / (0.5 * DegToRad(0.53));
    worst = std::max(worst, std::abs(visibility - DiskFractionAbove(offset)));
  }
  ASSERT_FALSE(std::isnan(first_lit));
  ASSERT_FALSE(std::isnan(first_full));
  EXPECT_NEAR(first_full - first_lit, width_m, 0.03 * width_m + 0.002);
  EXPECT_NEAR(0.5 * (first_full + first_lit), edge_x, 0.003);
  EXPECT_LT(worst, 0.02) << "visibility profile vs the analytic disk fraction";
}

TEST(WorldTest, SunBelowTheHorizonGivesNoDirectLight) {
  Scene scene = BaseScene();
  scene.time = ParseIso8601("2026-06-21T00:30:00+03:00").utc;  // night in Athens
  scene.objects.push_back(Ground(100.0, Eigen::Vector3d::Constant(0.5)));
  scene.sky = Sky::Uniform({1.0, 1.0, 1.0});
  const World world(scene);
  ASSERT_LT(world.SunDirection(scene.time).z(), 0.0);
  const GroundTruth truth = world.Render(DownCamera({0, 0, 2}, 8, 40.0));
  for (int v = 0; v < 8; ++v) {
    for (int u = 0; u < 8; ++u) {
      EXPECT_EQ(truth.sun_visibility.at<float>(v, u), 0.0f);
      EXPECT_NEAR(truth.irradiance.at<cv::Vec3f>(v, u)[0], kPi, 1e-5);  // the sky only
    }
  }
  // A sun just below the horizon, given directly: no light even on a wall facing it.
  scene.sun.direction_in_enu = Direction(270.0, -1.0);
  const World low(scene);
  const GroundTruth truth_low = low.Render(DownCamera({0, 0, 2}, 8, 40.0));
  EXPECT_EQ(cv::countNonZero(truth_low.sun_visibility), 0);
}

TEST(WorldTest, LampsFollowTheInverseSquareLawAndTheSpotCone) {
  Scene scene = BaseScene();
  scene.sun.enabled = false;
  scene.objects.push_back(Ground(20.0, Eigen::Vector3d::Constant(0.5)));
  Lamp lamp;
  lamp.name = "spot";
  lamp.type = Lamp::Type::kSpot;
  lamp.position = {0, 0, 2};
  lamp.intensity_w_sr = {50, 40, 30};
  lamp.direction = -Eigen::Vector3d::UnitZ();
  lamp.cone_half_angle_rad = DegToRad(30.0);
  lamp.falloff_rad = 0.0;
  scene.lamps.push_back(lamp);
  const World world(scene);
  const PinholeCamera camera = DownCamera({0.1, 0.2, 3.0}, 64, 90.0);
  const GroundTruth truth = world.Render(camera);
  int inside = 0, outside = 0;
  for (int v = 0; v < 64; ++v) {
    for (int u = 0; u < 64; ++u) {
      const Eigen::Vector3d d = camera.world_from_camera.linear() * camera.intrinsics.Unproject({u + 0.5, v + 0.5});
      const Eigen::Vector3d p = camera.world_from_camera.translation() + truth.depth_m.at<float>(v, u) * d;
      const Eigen::Vector3d to_lamp = lamp.position - p;
      const double r = to_lamp.norm();
      const double angle = std::acos(2.0 / r);
      if (std::abs(angle - lamp.cone_half_angle_rad) < 0.01) continue;
      const double expected = angle < lamp.cone_half_angle_rad ? 50.0 * (2.0 / r) / (r * r) : 0.0;
      (expected > 0 ? inside : outside)++;
      EXPECT_NEAR(truth.irradiance.at<cv::Vec3f>(v, u)[0], expected, 1e-4 * 50.0) << p.transpose();
    }
  }
  EXPECT_GT(inside, 300);
  EXPECT_GT(outside, 300);
}

TEST(WorldTest, MovingObjectIsWhereItsMotionSays) {
  Scene scene = BaseScene();
  scene.sun.direction_in_enu = Direction(0.0, 90.0);
  scene.objects.push_back(Ground(20.0, Eigen::Vector3d::Constant(0.3)));
  SceneObject ball;
  ball.name = "ball";
  ball.shape = SceneObject::Shape::kSphere;
  ball.sphere_center = {-1.0, 0.0, 0.5};
  ball.sphere_radius_m = 0.25;
  ball.motion.type = Motion::Type::kLinear;
  ball.motion.reference_time = scene.time;
  ball.motion.velocity_mps = {0.4, 0.1, 0.0};
  scene.objects.push_back(ball);
  const World world(scene);
  const PinholeCamera camera = DownCamera({0, 0, 5}, 100, 60.0);
  double worst_sphere_error = 0.0;
  for (double dt_s : {0.0, 2.5, 5.0}) {
    const UtcTime t = scene.time + std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(dt_s));
    const Eigen::Vector3d center = ball.sphere_center + ball.motion.velocity_mps * dt_s;
    EXPECT_LT((world.ObjectOffset(1, t) - ball.motion.velocity_mps * dt_s).norm(), 1e-9);
    const GroundTruth truth = world.Render(camera, t);
    int on_ball = 0;
    for (int v = 0; v < 100; ++v) {
      for (int u = 0; u < 100; ++u) {
        // Where the moved sphere is, analytically: ray-sphere in double precision.
        const Eigen::Vector3d d = camera.world_from_camera.linear() * camera.intrinsics.Unproject({u + 0.5, v + 0.5});
        const Eigen::Vector3d o = camera.world_from_camera.translation() - center;
        const double a = d.squaredNorm(), b = 2 * o.dot(d), c = o.squaredNorm() - 0.0625;
        const double disc = b * b - 4 * a * c;
        if (std::abs(disc) < 1e-3 * b * b) continue;  // grazing
        if (disc > 0) {
          ++on_ball;
          ASSERT_EQ(truth.object_id.at<int>(v, u), 1) << "dt " << dt_s;
          const double t_exact = (-b - std::sqrt(disc)) / (2 * a);
          worst_sphere_error = std::max(worst_sphere_error, std::abs(truth.depth_m.at<float>(v, u) - t_exact));
          EXPECT_NEAR(truth.depth_m.at<float>(v, u), t_exact, 1e-4);
          continue;
        }
        ASSERT_EQ(truth.object_id.at<int>(v, u), 0);
        // The sun at the zenith: the ball's shadow is the disk of radius r under its centre.
        const Eigen::Vector3d p = camera.world_from_camera.translation() + truth.depth_m.at<float>(v, u) * d;
        const double from_axis = (p - center).head<2>().norm();
        if (from_axis < 0.24) {
          EXPECT_EQ(truth.sun_visibility.at<float>(v, u), 0.0f);
        } else if (from_axis > 0.26) {
          EXPECT_EQ(truth.sun_visibility.at<float>(v, u), 1.0f);
        }
      }
    }
    EXPECT_GT(on_ball, 30);
  }
  // Embree's single-precision sphere test is as good as the float of the depth image (under
  // 0.5 ppm at 4.75 m), so depth-derived normals see no error from the renderer.
  EXPECT_LT(worst_sphere_error, 2e-6);
}

TEST(WorldTest, CircularAndPathMotions) {
  Motion circle;
  circle.type = Motion::Type::kCircular;
  circle.reference_time = ParseIso8601("2026-01-01T00:00:00Z").utc;
  circle.center = {1, 1, 0};
  circle.period_s = 8.0;
  const Eigen::Vector3d anchor(2, 1, 0.5);
  const UtcTime quarter = circle.reference_time + std::chrono::seconds(2);
  EXPECT_LT((anchor + circle.OffsetAt(quarter, anchor) - Eigen::Vector3d(1, 2, 0.5)).norm(), 1e-12);
  Motion path;
  path.type = Motion::Type::kPath;
  path.reference_time = circle.reference_time;
  path.waypoints = {{0.0, {0, 0, 2}}, {10.0, {4, 0, 2}}, {20.0, {4, 4, 2}}};
  const Eigen::Vector3d lamp(0, 0, 2);
  EXPECT_LT((path.OffsetAt(path.reference_time + std::chrono::seconds(15), lamp) - Eigen::Vector3d(4, 2, 0)).norm(),
            1e-12);
  EXPECT_LT((path.OffsetAt(path.reference_time - std::chrono::seconds(5), lamp)).norm(), 1e-12);  // held before
  EXPECT_LT((path.OffsetAt(path.reference_time + std::chrono::hours(1), lamp) - Eigen::Vector3d(4, 4, 0)).norm(),
            1e-12);
}

TEST(WorldTest, IndirectLightInASphericalCavityMatchesTheSeriesInAlbedo) {
  // A point lamp at the centre of a closed sphere: every bounce spreads the reflected flux
  // evenly over the inside, so E_direct = I / R^2 and E_indirect = I / R^2 (rho + ... + rho^N).
  Scene scene = BaseScene();
  scene.sun.enabled = false;
  SceneObject cavity;
  cavity.name = "cavity";
  cavity.shape = SceneObject::Shape::kSphere;
  cavity.sphere_center = {0, 0, 0};
  cavity.sphere_radius_m = 2.0;
  cavity.albedo = Eigen::Vector3d::Constant(0.5);
  scene.objects.push_back(cavity);
  Lamp lamp;
  lamp.name = "bulb";
  lamp.position = {0, 0, 0};
  lamp.intensity_w_sr = Eigen::Vector3d::Constant(40.0);
  scene.lamps.push_back(lamp);
  const PinholeCamera camera =
      PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(24, 24, DegToRad(60.0)), {0.3, 0, 0}, {1, 0, 0});
  for (int bounces : {0, 1, 2}) {
    scene.render.indirect_bounces = bounces;
    scene.render.indirect_samples = 64;
    const World world(scene);
    const GroundTruth truth = world.Render(camera);
    double expected = 10.0;  // I / R^2
    for (int k = 1; k <= bounces; ++k) expected += 10.0 * std::pow(0.5, k);
    const cv::Scalar mean = cv::mean(truth.irradiance);
    EXPECT_NEAR(mean[0], expected, 0.01 * expected) << bounces << " bounces";
    EXPECT_EQ(cv::countNonZero(truth.object_id != 0), 0);
  }
}

TEST(WorldTest, RenderingIsDeterministicAndThreadSafe) {
  Scene scene = LoadScene("config/scenes/tabletop-moving.yaml");
  scene.render.indirect_bounces = 1;
  scene.render.indirect_samples = 4;
  scene.render.threads = 1;
  const World one_thread(scene);
  scene.render.threads = 2;
  const World two_threads(scene);
  const PinholeCamera camera = two_threads.Camera("rgbd", 48, 36);
  const UtcTime t1 = scene.time + std::chrono::seconds(1);
  const GroundTruth reference = one_thread.Render(camera, t1);
  GroundTruth a, b;
  std::thread first([&] { a = two_threads.Render(camera, t1); });
  std::thread second([&] { b = two_threads.Render(camera, scene.time + std::chrono::seconds(3)); });
  first.join();
  second.join();
  EXPECT_EQ(cv::norm(a.radiance.pixels, reference.radiance.pixels, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(b.radiance.pixels, reference.radiance.pixels, cv::NORM_INF), 0.0);  // the object moved
}

TEST(WorldTest, UtmAndEnuVariantsOfTheOutdoorSceneAgree) {
  const Scene enu_scene = LoadScene("config/scenes/outdoor-building.yaml");
  const Scene utm_scene = LoadScene("config/scenes/outdoor-building-utm.yaml");
  ASSERT_EQ(utm_scene.utm_zone, 34);
  const World enu(enu_scene), utm(utm_scene);
  for (const char* name : {"aerial", "west"}) {
    const GroundTruth a = enu.Render(enu.Camera(name, 96, 72));
    const GroundTruth b = utm.Render(utm.Camera(name, 96, 72));
    cv::Mat differ = cv::abs(a.sun_visibility - b.sun_visibility) > 0.2;
    EXPECT_LE(cv::countNonZero(differ), 3) << name;  // at most a few pixels on shadow edges
    const double relative =
        cv::norm(a.radiance.pixels, b.radiance.pixels, cv::NORM_L1) / cv::norm(a.radiance.pixels, cv::NORM_L1);
    EXPECT_LT(relative, 2e-3) << name;
  }
  // The check can fail: a loader that copied the grid frame as if it were ENU would rotate
  // the sun by the meridian convergence (1.68 deg here) and move the shadows.
  Scene wrong = utm_scene;
  const UtmGridFrame grid(utm_scene.site, 34);
  wrong.sun.direction_in_enu = grid.GridFromEnuDirection(enu.SunDirection(enu_scene.time));
  const World wrong_world(wrong);
  const GroundTruth a = enu.Render(enu.Camera("aerial", 96, 72));
  const GroundTruth c = wrong_world.Render(wrong_world.Camera("aerial", 96, 72));
  EXPECT_GT(cv::countNonZero(cv::abs(a.sun_visibility - c.sun_visibility) > 0.2), 10);
}

TEST(WorldTest, ColorCheckerPatchesShowTheirReferenceAlbedo) {
  const Scene scene = LoadScene("config/scenes/colorchecker.yaml");
  const World world(scene);
  const int chart = scene.ObjectIndex("chart");
  ASSERT_GE(chart, 0);
  const ColorCheckerLayout& layout = *scene.objects[static_cast<std::size_t>(chart)].colorchecker;
  const PinholeCamera camera = world.Camera("front");
  const GroundTruth truth = world.Render(camera);
  ASSERT_EQ(layout.centers_in_world.size(), 24u);
  for (std::size_t i = 0; i < 24; ++i) {
    const Eigen::Vector2d pixel =
        camera.intrinsics.Project(camera.world_from_camera.inverse() * layout.centers_in_world[i]);
    const int u = static_cast<int>(pixel.x()), v = static_cast<int>(pixel.y());
    EXPECT_EQ(truth.object_id.at<int>(v, u), chart);
    EXPECT_LT((Rgb(truth.albedo, u, v) - layout.albedo[i]).norm(), 1e-6) << layout.names[i];
  }
  // Cyan's linear R is -0.044 in the reference: clamped to 0.
  EXPECT_EQ(layout.names[17], "cyan");
  EXPECT_EQ(layout.albedo[17].x(), 0.0);
}

TEST(WorldTest, ShippedScenesLoadAndRenderEveryCamera) {
  for (const char* file :
       {"outdoor-building", "outdoor-building-utm", "indoor-room", "tabletop", "tabletop-moving", "colorchecker"}) {
    const Scene scene = LoadScene(std::string("config/scenes/") + file + ".yaml");
    ASSERT_FALSE(scene.cameras.empty()) << file;
    RenderOptions fast = scene.render;
    fast.sky_samples = 4;
    fast.sun_samples = 2;
    fast.indirect_bounces = 0;
    const World world(scene, fast);
    for (const std::string& name : world.CameraNames()) {
      const GroundTruth truth = world.Render(world.Camera(name, 32, 24));
      EXPECT_GT(cv::countNonZero(truth.object_id >= 0), 32 * 24 / 4) << file << " " << name;
      const cv::Mat finite = truth.radiance.pixels == truth.radiance.pixels;  // no NaN radiance
      EXPECT_EQ(cv::countNonZero(finite.reshape(1)), 32 * 24 * 3) << file << " " << name;
      double max_irradiance = 0.0;
      cv::minMaxIdx(truth.irradiance.reshape(1), nullptr, &max_irradiance);
      EXPECT_GT(max_irradiance, 0.0) << file << " " << name;
    }
  }
}

TEST(WorldTest, IndoorLampNamedPositionsMoveTheShadows) {
  Scene scene = LoadScene("config/scenes/indoor-room.yaml");
  RenderOptions fast = scene.render;
  fast.indirect_bounces = 0;
  scene.SetLampPosition("lamp", "ceiling-center");
  const World a(scene, fast);
  scene.SetLampPosition("lamp", "window-corner");
  const World b(scene, fast);
  const GroundTruth ta = a.Render(a.Camera("door", 48, 36));
  const GroundTruth tb = b.Render(b.Camera("door", 48, 36));
  EXPECT_GT(cv::norm(ta.irradiance, tb.irradiance, cv::NORM_L1), 0.0);
  EXPECT_THROW(scene.SetLampPosition("lamp", "nowhere"), InvalidArgumentError);
}

TEST(WorldTest, UnknownCameraAndBadOptionsAreClearErrors) {
  Scene scene = BaseScene();
  scene.objects.push_back(Ground(1.0, Eigen::Vector3d::Constant(0.5)));
  const World world(scene);
  try {
    world.Camera("nosuch");
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("no camera named 'nosuch'"), std::string::npos);
  }
  RenderOptions bad;
  bad.sun_samples = 0;
  EXPECT_THROW(World(scene, bad), InvalidArgumentError);
  scene.objects[0].albedo = {1.2, 0.5, 0.5};
  EXPECT_THROW(World{scene}, InvalidArgumentError);
}

}  // namespace
}  // namespace relume::sim
