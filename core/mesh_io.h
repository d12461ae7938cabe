// Triangle mesh files as they are: Wavefront OBJ and ASCII PLY, read into MeshData (positions
// in the file's own frame, metres; faces as triangles; the file's colours and material names).
// The simulator reads the colours as albedo (sim/world/scene.h); processing reads geometry only.
//
// Supported:
//  - OBJ: `v x y z [r g b]` (optional per-vertex colour, linear, in [0, 1]), `f` with 3 or
//    more vertices (v, v/vt, v//vn, v/vt/vn; negative indices count from the end; polygons
//    are split into a fan), `usemtl NAME` (recorded per face). Other statements (vt, vn, o, g,
//    s, mtllib) are ignored.
//  - PLY: `format ascii 1.0` only. Element `vertex` with x, y, z and optional red, green,
//    blue (uchar: 8-bit sRGB-encoded, decoded to linear; float/double: linear in [0, 1]);
//    element `face` with a `vertex_indices` (or `vertex_index`) list and optional red, green,
//    blue (same rules). Other elements and properties are read and ignored.
// Errors name the file, the line and the statement (ConfigError), or the path (IoError).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace relume {

// Triangles with the colours and material names a file gave. Colour sources, first found wins:
// per-vertex (interpolated), per-face, the owner's (a scene object's albedo).
// Not a TriangleMesh (core/mesh.h), which the simulator and processing build from it once it is
// placed: a file's coordinates may be georeferenced (float steps are 3 cm at a UTM easting of
// 500 km, 50 cm at a northing of 5000 km), so they stay double until placement subtracts the
// offset (core/scene_model_file.h MeshPlacement).
struct MeshData {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;      // vertex indices
  std::vector<Eigen::Vector3d> vertex_albedo;  // empty, or one per vertex (NaN = not given); linear
  std::vector<Eigen::Vector3d> face_albedo;    // empty, or one per triangle (NaN = not given); linear
  std::vector<std::string> face_material;      // empty, or one per triangle (OBJ usemtl)

  void Append(const MeshData& other);
  bool IsValid(std::string* why) const;
};

MeshData LoadObjMesh(const std::string& path);
MeshData LoadPlyMesh(const std::string& path);
// By extension (.obj, .ply, case-insensitive); InvalidArgumentError for any other extension.
MeshData LoadMesh(const std::string& path);

}  // namespace relume
