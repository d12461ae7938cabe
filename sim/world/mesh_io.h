// Small readers for triangle meshes: Wavefront OBJ and ASCII PLY.
//
// Supported:
//  - OBJ: `v x y z [r g b]` (optional per-vertex colour, linear, in [0, 1]), `f` with 3 or
//    more vertices (v, v/vt, v//vn, v/vt/vn; negative indices count from the end; polygons
//    are split into a fan), `usemtl NAME` (recorded per face, so a scene can give each
//    material an albedo). Other statements (vt, vn, o, g, s, mtllib) are ignored.
//  - PLY: `format ascii 1.0` only. Element `vertex` with x, y, z and optional red, green,
//    blue (uchar: 8-bit sRGB-encoded, decoded to linear; float/double: linear in [0, 1]);
//    element `face` with a `vertex_indices` (or `vertex_index`) list and optional red, green,
//    blue (same rules). Other elements and properties are read and ignored.
// Errors name the file, the line and the statement (ConfigError), or the path (IoError).
#pragma once

#include <string>

#include "sim/world/scene.h"

namespace relume::sim {

TriangleMesh LoadObjMesh(const std::string& path);
TriangleMesh LoadPlyMesh(const std::string& path);
// By extension (.obj, .ply, case-insensitive); InvalidArgumentError for any other extension.
TriangleMesh LoadMesh(const std::string& path);

}  // namespace relume::sim
