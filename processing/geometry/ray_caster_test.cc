#include "processing/geometry/ray_caster.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/parallel.h"

namespace relume {
namespace {

TEST(RayCasterTest, HitsAndMisses) {
  const TriangleMesh ground = MakeQuad({-5, -5, 0}, {10, 0, 0}, {0, 10, 0}, 4);
  const RayCaster caster(ground);
  const RayCaster::Hit hit = caster.Intersect({1, 2, 3}, {0, 0, -1}, 0, 100);
  ASSERT_TRUE(hit.valid);
  EXPECT_NEAR(hit.t, 3.0f, 1e-5f);
  EXPECT_NEAR(caster.Interpolate(ground.positions, hit).x(), 1.0f, 1e-5f);
  EXPECT_FALSE(caster.Intersect({1, 2, 3}, {0, 0, 1}, 0, 100).valid);
  EXPECT_TRUE(caster.Occluded({0, 0, 1}, {0, 0, -1}, 0, 2));
  EXPECT_FALSE(caster.Occluded({0, 0, 1}, {0, 0, -1}, 0, 0.5f));
}

TEST(RayCasterTest, CameraRowsMatchSingleRays) {
  const TriangleMesh box = MakeBox({-1, -1, 0}, {1, 1, 2}, 3);
  const RayCaster caster(box);
  const PinholeCamera camera =
      PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(37, 20, 1.0), {6, -5, 3}, {0, 0, 1});
  std::vector<RayCaster::Hit> row(37);
  caster.IntersectCameraRow(camera, 10, 0, 37, row);
  int hits = 0;
  for (int x = 0; x < 37; ++x) {
    const Eigen::Vector3f d =
        (camera.world_from_camera.linear() * camera.intrinsics.Unproject({x + 0.5, 10.5})).cast<float>().normalized();
    const RayCaster::Hit single =
        caster.Intersect(camera.world_from_camera.translation().cast<float>(), d, 0, INFINITY);
    ASSERT_EQ(single.valid, row[static_cast<std::size_t>(x)].valid) << x;
    if (single.valid) {
      ++hits;
      EXPECT_NEAR(single.t, row[static_cast<std::size_t>(x)].t, 1e-4f);
    }
  }
  EXPECT_GT(hits, 5);
}

TEST(RayCasterTest, SunFractionAcrossAShadowEdge) {
  // A wall 10 m tall casts a shadow; the penumbra at distance d from its top edge is
  // d * 0.533 deg wide. Fractions go 1 -> 0 across it.
  TriangleMesh scene = MakeQuad({-50, -50, 0}, {100, 0, 0}, {0, 100, 0}, 2);
  scene.Append(
      MakeQuad({-50, 0, 0}, {0, 0, 10}, {100, 0, 0}, 1));  // wall in the plane y = 0 facing -y... both sides cast
  const RayCaster caster(scene);
  const float elevation = 45.0f * 3.14159265f / 180.0f;
  const Eigen::Vector3f sun(0, std::cos(elevation), std::sin(elevation));  // sun due north
  const float radius = 0.5f * 0.533f * 3.14159265f / 180.0f;
  // The shadow edge on the ground is at y = -10 (45 deg); the penumbra there is about
  // 14.1 m * 0.0093 rad / sin(45) = 0.19 m wide.
  EXPECT_NEAR(SunVisibleFraction(caster, {0, -9.5f, 0}, {0, 0, 1}, sun, radius, 64), 0.0f, 1e-6f);
  EXPECT_NEAR(SunVisibleFraction(caster, {0, -10.5f, 0}, {0, 0, 1}, sun, radius, 64), 1.0f, 1e-6f);
  const float middle = SunVisibleFraction(caster, {0, -10.0f, 0}, {0, 0, 1}, sun, radius, 64);
  EXPECT_GT(middle, 0.3f);
  EXPECT_LT(middle, 0.7f);
}

TEST(RayCasterTest, PacketRaysAnswerAsSingleRays) {
  // The wall and ground of the shadow-edge test: rays from points on both sides of the shadow
  // edge, toward directions over the sun's disk and the whole sky, some lanes switched off.
  TriangleMesh scene = MakeQuad({-50, -50, 0}, {100, 0, 0}, {0, 100, 0}, 8);
  scene.Append(MakeQuad({-50, 0, 0}, {0, 0, 10}, {100, 0, 0}, 4));
  const RayCaster caster(scene);
  const float elevation = 45.0f * 3.14159265f / 180.0f;
  const Eigen::Vector3f sun(0, std::cos(elevation), std::sin(elevation));
  const std::vector<Eigen::Vector3f> disk = SunDiskDirections(sun, 0.02f, 37);  // not a multiple of 16
  ASSERT_EQ(disk.size(), 37u);
  std::vector<Eigen::Vector3f> sky;
  for (int i = 0; i < 50; ++i) {
    const float a = 0.7f * static_cast<float>(i), z = 0.02f * static_cast<float>(i) - 0.1f;
    sky.push_back(Eigen::Vector3f(std::cos(a), std::sin(a), z).normalized());
  }
  int blocked = 0, open = 0;
  for (float y = -10.3f; y <= -9.7f; y += 0.05f) {
    const Eigen::Vector3f origin(0.3f, y, 0.01f);
    for (const std::vector<Eigen::Vector3f>* directions :
         {&disk, static_cast<const std::vector<Eigen::Vector3f>*>(&sky)}) {
      std::vector<std::uint8_t> use(directions->size());
      int expected = 0;
      for (std::size_t i = 0; i < directions->size(); ++i) {
        use[i] = i % 5 != 3;
        if (!use[i]) continue;
        const bool occluded = caster.Occluded(origin, (*directions)[i], 0.0f, INFINITY);
        expected += occluded ? 0 : 1;
        (occluded ? blocked : open) += 1;
      }
      EXPECT_EQ(caster.CountUnoccluded(origin, *directions, use, 0.0f, INFINITY, directions == &disk), expected) << y;
    }
  }
  EXPECT_GT(blocked, 100);
  EXPECT_GT(open, 100);
  // SunVisibleFraction through the disk's directions: one ray per direction, those behind the
  // surface counted as blocked.
  for (float y = -10.3f; y <= -9.7f; y += 0.05f) {
    const Eigen::Vector3f point(0.3f, y, 0.0f), normal(0, 0, 1);
    int visible = 0;
    for (const Eigen::Vector3f& d : disk) {
      const Eigen::Vector3f origin = point + normal * (2.0f * caster.epsilon());
      visible += d.dot(normal) > 0.0f && !caster.Occluded(origin, d, 4.0f * caster.epsilon(), INFINITY);
    }
    EXPECT_EQ(SunVisibleFraction(caster, point, normal, disk), static_cast<float>(visible) / 37.0f) << y;
    EXPECT_EQ(SunVisibleFraction(caster, point, normal, sun, 0.02f, 37), static_cast<float>(visible) / 37.0f) << y;
  }
  // One sample: the sun's centre.
  EXPECT_EQ(SunDiskDirections(sun, 0.02f, 1).front(), sun.normalized());
}

TEST(RayCasterTest, SkyViewMatchesAnalyticViewFactors) {
  // Open ground: the whole sky. A tilted open plane: (1 + n_z) / 2.
  const TriangleMesh ground = MakeQuad({-50, -50, 0}, {100, 0, 0}, {0, 100, 0}, 2);
  const RayCaster open(ground);
  EXPECT_NEAR(SkyViewFraction(open, {0, 0, 0}, {0, 0, 1}, 256), 1.0f, 1e-6f);
  const Eigen::Vector3f tilted = Eigen::Vector3f(1, 0, 1).normalized();
  EXPECT_NEAR(SkyViewFraction(open, {0, 0, 5}, tilted, 1024), 0.5f * (1.0f + tilted.z()), 0.02f);
  EXPECT_NEAR(SkyViewFraction(open, {0, 0, 5}, {1, 0, 0}, 1024), 0.5f, 0.02f);
  // An open vertical wall sees exactly half of its pattern as sky at the IRM's sample counts:
  // no direction lies on its horizon (until 2026-12-03: 0.458 at 144, 0.4375 at 64).
  for (const int samples : {64, 144}) {
    for (const Eigen::Vector3f& wall_normal : {Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(0, -1, 0)}) {
      EXPECT_FLOAT_EQ(SkyViewFraction(open, {0, 0, 5}, wall_normal, samples), 0.5f) << samples << " samples";
    }
  }
  // The ground 0.5 m from a wall 1000 m tall and 2000 m long: half the sky (view factor of a
  // strip beside an infinite wall, (1 + cos(atan(1000 / 0.5))) / 2), and a point 10 m away
  // from a 10 m wall:
  // (1 + cos(atan(10 / 10))) / 2 = (1 + 0.7071) / 2 of the sky.
  const TriangleMesh wall = MakeQuad({5, -1000, 0}, {0, 2000, 0}, {0, 0, 1000}, 1);
  const TriangleMesh low = MakeQuad({5, -1000, 0}, {0, 2000, 0}, {0, 0, 10}, 1);
  for (const TriangleMesh* w : {&wall, &low}) {
    TriangleMesh both = ground;
    both.Append(*w);
    const RayCaster caster(both);
    if (w == &wall) {
      EXPECT_NEAR(SkyViewFraction(caster, {4.5f, 0, 0}, {0, 0, 1}, 1024), 0.5f, 0.02f);
    } else {
      EXPECT_NEAR(SkyViewFraction(caster, {-5, 0, 0}, {0, 0, 1}, 1024), 0.5f * (1.0f + std::sqrt(0.5f)), 0.02f);
    }
  }
}

TEST(RayCasterTest, SkyZenithMomentMatchesAnalyticIntegrals) {
  // m = (1/pi) int z max(0, n . w) over the unblocked sky (w_z > 0).
  const TriangleMesh ground = MakeQuad({-50, -50, 0}, {100, 0, 0}, {0, 100, 0}, 2);
  const RayCaster open(ground);
  // Open ground: (1/pi) int cos^2 = 2/3, with the same sky view as SkyViewFraction.
  const SkyView up = SkyViewMoments(open, {0, 0, 0}, {0, 0, 1}, 1024);
  EXPECT_NEAR(up.view, 1.0f, 1e-6f);
  EXPECT_NEAR(up.zenith_moment, 2.0f / 3.0f, 0.01f);
  EXPECT_EQ(up.view, SkyViewFraction(open, {0, 0, 0}, {0, 0, 1}, 1024));
  // An open vertical wall facing +x: (1/pi) int_{z>0, x>0} z x = (1/pi) (2)(1/3) = 2 / (3 pi).
  const SkyView wall_face = SkyViewMoments(open, {0, 0, 5}, {1, 0, 0}, 1024);
  EXPECT_NEAR(wall_face.view, 0.5f, 0.02f);
  EXPECT_NEAR(wall_face.zenith_moment, 2.0f / (3.0f * std::numbers::pi_v<float>), 0.01f);
  // The ground at the foot of a very tall, long wall: half of open ground's sky, both moments.
  TriangleMesh both = ground;
  both.Append(MakeQuad({5, -1000, 0}, {0, 2000, 0}, {0, 0, 1000}, 1));
  const RayCaster caster(both);
  const SkyView foot = SkyViewMoments(caster, {4.5f, 0, 0}, {0, 0, 1}, 1024);
  EXPECT_NEAR(foot.view, 0.5f, 0.02f);
  EXPECT_NEAR(foot.zenith_moment, 1.0f / 3.0f, 0.015f);  // plus the sliver above the wall 0.5 m away
  // Below the horizon there is no sky: a downward normal sees none of either.
  const SkyView down = SkyViewMoments(open, {0, 0, 5}, {0, 0, -1}, 256);
  EXPECT_EQ(down.view, 0.0f);
  EXPECT_EQ(down.zenith_moment, 0.0f);
}

// Ground 10 m x 10 m, a wall 2 m tall across x = 1 (facing -x), and a roof 1 m up over
// x in [3, 5] (facing down).
TriangleMesh GroundWallRoof() {
  TriangleMesh scene = MakeQuad({-5, -5, 0}, {10, 0, 0}, {0, 10, 0}, 4);
  scene.Append(MakeQuad({1, -5, 0}, {0, 0, 2}, {0, 10, 0}, 1));
  scene.Append(MakeQuad({3, -5, 1}, {0, 10, 0}, {2, 0, 0}, 1));
  return scene;
}

TEST(RayCasterTest, OffsetPolicyScalesWithTheMesh) {
  const TriangleMesh scene = GroundWallRoof();
  const RayCaster caster(scene);
  const float diagonal = std::sqrt(10.0f * 10.0f + 10.0f * 10.0f + 2.0f * 2.0f);
  EXPECT_FLOAT_EQ(caster.epsilon(), 1e-5f * diagonal);
  EXPECT_EQ(caster.surface_lift(), 2.0f * caster.epsilon());
  EXPECT_EQ(caster.surface_skip(), 4.0f * caster.epsilon());
  // A tiny mesh gets the floor of 1e-6 m.
  const RayCaster tiny(MakeQuad({0, 0, 0}, {1e-3f, 0, 0}, {0, 1e-3f, 0}, 1));
  EXPECT_EQ(tiny.epsilon(), 1e-6f);
}

TEST(RayCasterTest, SegmentsBetweenSurfacePoints) {
  const RayCaster caster(GroundWallRoof());
  const Eigen::Vector3d up(0, 0, 1), toward_minus_x(-1, 0, 0), down(0, 0, -1), free(0, 0, 0);
  // Ground to ground across the wall: blocked; on the same side: open, in both directions.
  EXPECT_TRUE(caster.SegmentOccluded({0, 0, 0}, up, {2, 0, 0}, up));
  EXPECT_TRUE(caster.SegmentOccluded({2, 0, 0}, up, {0, 0, 0}, up));
  EXPECT_FALSE(caster.SegmentOccluded({-4, 0, 0}, up, {0, 0, 0}, up));
  EXPECT_FALSE(caster.SegmentOccluded({0, 0, 0}, up, {-4, 0, 0}, up));
  // The wall's face and the ground before it see each other, right down to the crease: a point
  // at the wall's foot does not shadow itself (the skip), nor does the wall point.
  EXPECT_FALSE(caster.SegmentOccluded({0, 0, 0}, up, {1, 0, 1}, toward_minus_x));
  EXPECT_FALSE(caster.SegmentOccluded({1.0 - 1e-5, 0, 0}, up, {1, 0, 1}, toward_minus_x));
  EXPECT_FALSE(caster.SegmentOccluded({0, 0, 0}, up, {1, 0, 1e-5}, toward_minus_x));
  // Ground under the roof and the roof's underside: open; a lamp above the roof: blocked.
  EXPECT_FALSE(caster.SegmentOccluded({4, 0, 0}, up, {4, 1, 1}, down));
  EXPECT_TRUE(caster.SegmentOccluded({4, 0, 0}, up, {4, 0, 3}, free));
  EXPECT_FALSE(caster.SegmentOccluded({-2, 0, 0}, up, {-2, 0, 3}, free));
  // Ends that meet after lifting: nothing between them.
  EXPECT_FALSE(caster.SegmentOccluded({0, 0, 0}, up, {0, 0, 0}, up));
}

TEST(RayCasterTest, RaysFromSurfacePoints) {
  const RayCaster caster(GroundWallRoof());
  const Eigen::Vector3d up(0, 0, 1);
  EXPECT_TRUE(caster.RayOccluded({4, 0, 0}, up, up));                                       // under the roof
  EXPECT_FALSE(caster.RayOccluded({0, 0, 0}, up, up));                                      // open sky
  EXPECT_TRUE(caster.RayOccluded({0, 0, 0}, up, Eigen::Vector3d(1, 0, 1).normalized()));    // the wall
  EXPECT_FALSE(caster.RayOccluded({0, 0, 0}, up, Eigen::Vector3d(-1, 0, 1).normalized()));  // away from it
  // A grazing ray toward the wall: blocked from 1 cm, but from 10 um (inside the skip, 4 epsilon
  // = 0.4 mm here) the wall counts as the point's own crease, the policy's stated price.
  const Eigen::Vector3d grazing = Eigen::Vector3d(1, 0, 0.01).normalized();
  EXPECT_TRUE(caster.RayOccluded({1.0 - 1e-2, 0, 0}, up, grazing));
  EXPECT_FALSE(caster.RayOccluded({1.0 - 1e-5, 0, 0}, up, grazing));
  // Grazing along the ground away from the wall: the ground it leaves does not block it.
  EXPECT_FALSE(caster.RayOccluded({1.0 - 1e-5, 0, 0}, up, Eigen::Vector3d(-1, 0, 1e-3).normalized()));
  // The raw query, unlifted and unskipped from the ground itself, would call that blocked or not
  // depending on float rounding; the surface query adds exactly the policy's lift and skip.
  const Eigen::Vector3f from(0.5f, 0.25f, 0.0f), dir = Eigen::Vector3f(1, 0, 1).normalized();
  EXPECT_EQ(
      caster.RayOccluded(from.cast<double>(), up, dir.cast<double>()),
      caster.Occluded(from + Eigen::Vector3f::UnitZ() * caster.surface_lift(), dir, caster.surface_skip(), INFINITY));
}

TEST(RayCasterTest, CountsEveryRayAcrossThreads) {
  const TriangleMesh scene = GroundWallRoof();
  const RayCaster caster(scene);
  EXPECT_EQ(caster.rays_cast(), 0);
  caster.Intersect({0, 0, 3}, {0, 0, -1}, 0, INFINITY);
  caster.Occluded({0, 0, 3}, {0, 0, -1}, 0, INFINITY);
  EXPECT_EQ(caster.rays_cast(), 2);
  caster.SegmentOccluded({0, 0, 0}, {0, 0, 1}, {2, 0, 0}, {0, 0, 1});
  caster.SegmentOccluded({0, 0, 0}, {0, 0, 1}, {0, 0, 0}, {0, 0, 1});  // no ray: the ends meet
  caster.RayOccluded({0, 0, 0}, {0, 0, 1}, {0, 0, 1});
  EXPECT_EQ(caster.rays_cast(), 4);
  // Packets count their active rays only.
  const std::vector<Eigen::Vector3f> directions(20, Eigen::Vector3f::UnitZ());
  std::vector<std::uint8_t> use(20, 1);
  use[3] = use[17] = 0;
  caster.CountUnoccluded({0, 0, 0.1f}, directions, use, 0.0f, INFINITY, true);
  EXPECT_EQ(caster.rays_cast(), 4 + 18);
  std::vector<RayCaster::Hit> hits(21);
  const PinholeCamera camera =
      PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(21, 5, 1.0), {-4, 0, 3}, {0, 0, 0});
  caster.IntersectCameraRow(camera, 2, 0, 21, hits);
  EXPECT_EQ(caster.rays_cast(), 4 + 18 + 21);
  // From several threads at once: no ray lost.
  const std::int64_t before = caster.rays_cast();
  ParallelForEach(
      0, 4000,
      [&](std::int64_t i) {
        const double x = -4.0 + 8.0 * static_cast<double>(i) / 4000.0;
        caster.SegmentOccluded({x, 0, 0}, {0, 0, 1}, {x, 1, 3}, {0, 0, 0});
      },
      4);
  EXPECT_EQ(caster.rays_cast() - before, 4000);
}

TEST(RayCasterTest, OwnsAMeshGivenByValue) {
  // A caster built from a temporary keeps the mesh: mesh() and Interpolate stay valid.
  const RayCaster caster(MakeQuad({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}, 2));
  EXPECT_EQ(caster.mesh().triangle_count(), 8u);
  const RayCaster::Hit hit = caster.Intersect({0.25f, 0.5f, 1}, {0, 0, -1}, 0, INFINITY);
  ASSERT_TRUE(hit.valid);
  EXPECT_NEAR(caster.Interpolate(caster.mesh().positions, hit).y(), 0.5f, 1e-6f);
}

}  // namespace
}  // namespace relume
