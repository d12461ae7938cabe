#include "core/mesh_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/color.h"
#include "core/error.h"

namespace relume {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::path(::testing::TempDir()) / name;
  std::ofstream(path) << text;
  return path.string();
}

template <typename F>
std::string ErrorOf(F&& load) {
  try {
    load();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(MeshIoTest, ObjQuadsNegativeIndicesMaterialsAndVertexColours) {
  const std::string path = Write("quad.obj",
                                 "# a quad and a triangle\n"
                                 "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\n"
                                 "vn 0 0 1\nusemtl red\nf 1//1 2//1 3//1 4//1\nusemtl blue\nf -1 -3 -2\n");
  const MeshData mesh = LoadObjMesh(path);
  ASSERT_EQ(mesh.triangles.size(), 3u);
  EXPECT_EQ(mesh.triangles[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(mesh.triangles[2], Eigen::Vector3i(3, 1, 2));
  EXPECT_EQ(mesh.face_material, (std::vector<std::string>{"red", "red", "blue"}));
  ASSERT_EQ(mesh.vertex_albedo.size(), 4u);
  EXPECT_EQ(mesh.vertex_albedo[1], Eigen::Vector3d(0, 1, 0));
  std::string why;
  EXPECT_TRUE(mesh.IsValid(&why)) << why;
}

TEST(MeshIoTest, ObjErrorsNameTheLine) {
  const std::string path = Write("bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
  EXPECT_EQ(ErrorOf([&] { LoadObjMesh(path); }), path + ":3: f: vertex 3 does not exist (2 so far)");
  const std::string nan = Write("nan.obj", "v 0 0 nan\n");
  EXPECT_EQ(ErrorOf([&] { LoadObjMesh(nan); }), nan + ":1: v: 'nan' is not a finite number");
}

TEST(MeshIoTest, AsciiPlyWithFaceAndVertexColours) {
  const std::string path = Write("tri.ply",
                                 "ply\nformat ascii 1.0\ncomment test\nelement vertex 4\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                                 "element face 1\nproperty list uchar int vertex_indices\n"
                                 "property float red\nproperty float green\nproperty float blue\nend_header\n"
                                 "0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 128 128 128\n"
                                 "4 0 1 2 3 0.25 0.5 0.75\n");
  const MeshData mesh = LoadPlyMesh(path);
  ASSERT_EQ(mesh.triangles.size(), 2u);
  ASSERT_EQ(mesh.face_albedo.size(), 2u);
  EXPECT_EQ(mesh.face_albedo[1], Eigen::Vector3d(0.25, 0.5, 0.75));          // float: linear as is
  EXPECT_NEAR(mesh.vertex_albedo[3].x(), SrgbDecode(128.0 / 255.0), 1e-12);  // uchar: sRGB-decoded
  EXPECT_EQ(mesh.vertex_albedo[0], Eigen::Vector3d(1, 0, 0));
}

TEST(MeshIoTest, PlyErrors) {
  const std::string binary = Write("bin.ply", "ply\nformat binary_little_endian 1.0\nend_header\n");
  EXPECT_EQ(ErrorOf([&] { LoadPlyMesh(binary); }),
            binary + ":2: format: only 'format ascii 1.0' is supported; convert binary PLY to ASCII");
  const std::string short_file = Write("short.ply",
                                       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                       "property float z\nend_header\n0 0 0\n1 0 0\n");
  EXPECT_EQ(ErrorOf([&] { LoadPlyMesh(short_file); }),
            short_file + ":9: vertex: the file ends after 2 of 3 vertex lines");
  const std::string bad_index = Write("idx.ply",
                                      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  EXPECT_EQ(ErrorOf([&] { LoadPlyMesh(bad_index); }), bad_index + ":13: face: vertex index 7 does not exist");
  EXPECT_NE(ErrorOf([] { LoadMesh("model.stl"); }).find("unknown format '.stl'"), std::string::npos);
}

TEST(MeshIoTest, ShippedUtmMeshLoads) {
  const MeshData mesh = LoadObjMesh("config/scenes/meshes/building-utm.obj");
  EXPECT_EQ(mesh.triangles.size(), 2u + 3 * 12u);
  EXPECT_GT(mesh.vertices[0].y(), 4e6);  // northing
}

}  // namespace
}  // namespace relume
