// The geometry the IRM pipeline relights with: a processing TriangleMesh (core/mesh.h) in the
// site's ENU frame, built from the session's scene model (core/scene_model.h), or from a mesh file.
//
// Conventions:
//  - Output positions are metres in ENU at the site (x east, y north, z up), the frame of the
//    scene model's cameras and of the frames' sun azimuth/elevation.
//  - Every input triangle is split into a regular grid of smaller ones (edges at most
//    `spacing_m`) with its own vertices and its flat normal (from its winding), so that the
//    IRM gets a vertex every `spacing_m` and normals never blend across a crease. Spheres of
//    the scene model are tessellated with smooth normals.
//  - A mesh in UTM (x easting, y northing, z ellipsoidal height) is converted point by point
//    through geodetic coordinates (GeographicLib), which applies the meridian convergence
//    (grid north is not true north) and the grid scale exactly.
#pragma once

#include <optional>
#include <string>

#include "core/mesh.h"
#include "core/mesh_io.h"
#include "core/scene_model.h"
#include "core/site.h"

namespace relume::pipeline {

struct IrmMeshOptions {
  double spacing_m = 0.5;    // largest edge of the split triangles
  int sphere_segments = 48;  // around a sphere's equator (half as many from pole to pole)
  bool IsValid(std::string* why) const;
};

// Splits and re-normals a mesh file's triangles (see the top of this file). Positions are taken as they are.
TriangleMesh ProcessingMeshFromData(const MeshData& mesh, const IrmMeshOptions& options);

// Every object of a session's scene model (core/scene_model.h): triangles split as above,
// spheres tessellated.
TriangleMesh ProcessingMeshFromModel(const SceneModel& model, const IrmMeshOptions& options);

enum class MeshFrame { kEnu, kUtm };

// A mesh file (OBJ or PLY, core/mesh_io.h) in ENU at `site`, or in UTM (zone: the
// site's standard zone when not given). The returned convergence is gamma in radians (0 for ENU).
struct LoadedSceneMesh {
  TriangleMesh mesh;
  double convergence_rad = 0.0;
  int utm_zone = 0;
};
LoadedSceneMesh LoadSceneMesh(const std::string& path, MeshFrame frame, const Site& site, std::optional<int> utm_zone,
                              const IrmMeshOptions& options);

}  // namespace relume::pipeline
