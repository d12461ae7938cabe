#include "processing/irm/indirect.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace relume::irm {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// A 200 m x 200 m ground of one radiance and a 1 m wall standing on it, facing -y.
struct GroundAndWall {
  TriangleMesh mesh;
  std::size_t ground_vertices = 0;
  GroundAndWall() {
    mesh = MakeQuad({-100, -100, 0}, {200, 0, 0}, {0, 200, 0}, 8);
    ground_vertices = mesh.vertex_count();
    // The wall's outward side is -y: edges x then z give normal x cross z = -y.
    mesh.Append(MakeQuad({-0.5f, 0, 0.5f}, {1, 0, 0}, {0, 0, 1}, 1));
    mesh.ComputeVertexNormals();
  }
};

// Seen from the middle of a vertical wall, the ground fills the lower half of the hemisphere:
// cosine-weighted, exactly half of the irradiance pi L (the plane is 100x the wall's height, so
// the horizon's missing sliver is below the estimate's noise).
TEST(IndirectGatherTest, AWallSeesHalfItsHemisphereAsGround) {
  GroundAndWall scene;
  const RayCaster caster(scene.mesh);
  const IndirectGather gather = IndirectGather::Build(caster, 400, nullptr, 2);
  const Eigen::Vector3f ground_radiance(2.0f, 1.0f, 0.5f);
  std::vector<Eigen::Vector3f> radiance(scene.mesh.vertex_count(), ground_radiance);
  // The wall's own radiance must not count for itself (it cannot see itself).
  for (std::size_t i = scene.ground_vertices; i < radiance.size(); ++i) radiance[i] = {100, 100, 100};
  const std::vector<Eigen::Vector3f> indirect = gather.Apply(radiance);
  for (std::size_t i = scene.ground_vertices; i < scene.mesh.vertex_count(); ++i) {
    const Eigen::Vector3f expected = 0.5f * kPi * ground_radiance;
    EXPECT_NEAR(indirect[i].x(), expected.x(), 0.03 * expected.x()) << "wall vertex " << i;
    EXPECT_NEAR(indirect[i].z(), expected.z(), 0.03 * expected.z()) << "wall vertex " << i;
  }
  // Open ground far from the wall sees only sky: nothing.
  EXPECT_EQ(indirect[0], Eigen::Vector3f::Zero());
  EXPECT_GT(gather.hit_share(), 0.0);
  EXPECT_LT(gather.hit_share(), 0.5);
}

// The projected solid angle of a convex polygon seen from a point with unit normal n
// (Lambert's formula): sum over the edges of the angle they subtend times the normal's component
// along the edge's plane normal, halved. A uniform polygon of radiance L gives irradiance L times it.
double ProjectedSolidAngle(const Eigen::Vector3d& point, const Eigen::Vector3d& n,
                           const std::vector<Eigen::Vector3d>& polygon) {
  double sum = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector3d a = (polygon[i] - point).normalized();
    const Eigen::Vector3d b = (polygon[(i + 1) % polygon.size()] - point).normalized();
    sum += std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * a.cross(b).normalized().dot(n);
  }
  return std::abs(sum) / 2.0;
}

// The ground in front of a wall receives what the wall's front sends, L times the projected
// solid angle the wall subtends (exact, Lambert's formula); the ground behind it gets nothing:
// a back face sends no light.
TEST(IndirectGatherTest, OnlyTheFrontOfASurfaceSendsLight) {
  TriangleMesh mesh = MakeQuad({-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 8);
  const std::size_t ground = mesh.vertex_count();
  mesh.Append(MakeQuad({-1, 0, 0}, {2, 0, 0}, {0, 0, 2}, 2));  // 2 m x 2 m, faces -y
  mesh.ComputeVertexNormals();
  const RayCaster caster(mesh);
  const IndirectGather gather = IndirectGather::Build(caster, 1024, nullptr, 2);
  std::vector<Eigen::Vector3f> radiance(mesh.vertex_count(), Eigen::Vector3f::Zero());
  for (std::size_t i = ground; i < radiance.size(); ++i) radiance[i] = Eigen::Vector3f::Ones();
  const std::vector<Eigen::Vector3f> indirect = gather.Apply(radiance);
  const std::vector<Eigen::Vector3d> wall{{-1, 0, 0}, {1, 0, 0}, {1, 0, 2}, {-1, 0, 2}};
  int checked = 0;
  for (std::size_t i = 0; i < ground; ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    if (std::abs(p.x()) > 1.01f || std::abs(p.y()) < 0.4f) continue;  // beside the wall, or at its foot
    if (p.y() > 0.0f) {
      EXPECT_EQ(indirect[i].x(), 0.0f) << "behind the wall at " << p.transpose();
    } else {
      const double expected = ProjectedSolidAngle(p.cast<double>(), Eigen::Vector3d::UnitZ(), wall);
      EXPECT_NEAR(indirect[i].x(), expected, 0.03 * expected + 0.01) << "in front of the wall at " << p.transpose();
    }
    ++checked;
  }
  EXPECT_GE(checked, 20);
}

TEST(IndirectGatherTest, OnlyTheNeededVerticesGather) {
  GroundAndWall scene;
  const RayCaster caster(scene.mesh);
  std::vector<std::uint8_t> needed(scene.mesh.vertex_count(), 0);
  needed.back() = 1;
  const IndirectGather gather = IndirectGather::Build(caster, 64, &needed, 1);
  EXPECT_EQ(gather.rays(), 64);
  const std::vector<Eigen::Vector3f> indirect =
      gather.Apply(std::vector<Eigen::Vector3f>(scene.mesh.vertex_count(), Eigen::Vector3f::Ones()));
  EXPECT_GT(indirect.back().x(), 0.0f);
  EXPECT_EQ(indirect[scene.ground_vertices].x(), 0.0f);
  // Only ground vertices are read (the wall cannot see itself).
  for (std::size_t i = scene.ground_vertices; i < scene.mesh.vertex_count(); ++i) EXPECT_EQ(gather.referenced()[i], 0);
}

}  // namespace
}  // namespace relume::irm
