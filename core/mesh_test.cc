#include "core/mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

namespace relume {
namespace {

TEST(MeshTest, BoxHasOutwardNormals) {
  const TriangleMesh box = MakeBox({0, 0, 0}, {2, 3, 4}, 2);
  std::string why;
  ASSERT_TRUE(box.IsValid(&why)) << why;
  EXPECT_EQ(box.triangle_count(), 6u * 2 * 2 * 2);
  const Eigen::Vector3f centre(1, 1.5, 2);
  for (std::size_t i = 0; i < box.vertex_count(); ++i) {
    EXPECT_GT(box.normals[i].dot(box.positions[i] - centre), 0.0f);
  }
  // Triangle winding agrees with the stored normals.
  TriangleMesh recomputed = box;
  recomputed.normals.clear();
  recomputed.ComputeVertexNormals();
  for (const Eigen::Vector3i& t : box.triangles) {
    const Eigen::Vector3f face =
        (box.positions[t[1]] - box.positions[t[0]]).cross(box.positions[t[2]] - box.positions[t[0]]);
    EXPECT_GT(face.dot(box.normals[t[0]]), 0.0f);
  }
}

TEST(MeshTest, ValidationCatchesBadIndices) {
  TriangleMesh mesh = MakeQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 1);
  mesh.triangles.emplace_back(0, 1, 99);
  std::string why;
  EXPECT_FALSE(mesh.IsValid(&why));
  mesh.triangles.pop_back();
  mesh.positions[0].x() = NAN;
  EXPECT_FALSE(mesh.IsValid(&why));
}

}  // namespace
}  // namespace relume
