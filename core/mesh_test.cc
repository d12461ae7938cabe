#include "core/mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

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

TEST(MeshTest, MaterialIdsArePerTriangleAndSurviveAppend) {
  TriangleMesh a = MakeQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 1);  // two triangles
  std::string why;
  a.material = {0};
  EXPECT_FALSE(a.IsValid(&why));
  EXPECT_NE(why.find("per triangle"), std::string::npos) << why;
  a.material = {0, -1};
  EXPECT_FALSE(a.IsValid(&why));
  EXPECT_NE(why.find("negative"), std::string::npos) << why;
  a.material = {0, 0};
  ASSERT_TRUE(a.IsValid(&why)) << why;

  TriangleMesh b = MakeQuad({0, 0, 1}, {1, 0, 0}, {0, 1, 0}, 2);  // eight triangles
  b.material.assign(b.triangle_count(), 3);
  TriangleMesh both;
  both.Append(a);
  both.Append(b);
  ASSERT_EQ(both.material.size(), 10u);
  EXPECT_EQ(both.material[1], 0);
  EXPECT_EQ(both.material[2], 3);
  EXPECT_EQ(both.triangles[2], b.triangles[0] + Eigen::Vector3i::Constant(4));
  EXPECT_TRUE(both.IsValid(&why)) << why;

  // A mesh without ids appended: the ids no longer cover every triangle, so none are kept.
  both.Append(MakeQuad({0, 0, 2}, {1, 0, 0}, {0, 1, 0}, 1));
  EXPECT_TRUE(both.material.empty());
  TriangleMesh none = MakeQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 1);
  none.Append(b);
  EXPECT_TRUE(none.material.empty());
  EXPECT_TRUE(none.IsValid(&why)) << why;
}

// The float steps core/mesh_io.h and radiosity/scene.h state: why a georeferenced file stays
// double until placed, and how fine a local scene frame is.
TEST(MeshTest, FloatStepsAtTheStatedDistances) {
  const auto step = [](float x) { return std::nextafter(x, 2.0f * x) - x; };
  EXPECT_FLOAT_EQ(step(500000.0f), 0.03125f);  // a UTM easting: 3 cm
  EXPECT_FLOAT_EQ(step(5000000.0f), 0.5f);     // a northing: 50 cm
  EXPECT_LE(step(7.9f), 1e-6f);                // 1 um within 8 m
  EXPECT_NEAR(step(1000.0f), 61e-6f, 1e-6f);   // 61 um at 1 km
}

}  // namespace
}  // namespace relume
