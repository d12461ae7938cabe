// A scene model written by hand (core/scene_model.h) for a real session: what a field team
// measured of the place (a camera's position with a tape or total station, a photogrammetry mesh,
// the lamps). `relume session add-scene-model S --from FILE` stores it in the session; the
// pipelines then read it like the model capture writes for simulated rigs. docs/real-data.md
// walks through one.
//
//   site: {latitude_deg: 37.97, longitude_deg: 23.72, height_m: 110}  # optional: the session's
//   frame: enu                  # enu (metres at the site, default) or utm (easting, northing,
//   utm_zone: 34                #   ellipsoidal height), for every position and mesh below
//                               #   unless an entry gives its own `frame:`
//   cameras:
//     - device: gphoto2:canon-eos   # the session's device id (`relume session info`)
//       intrinsics: {width: 6000, height: 4000, fx: 5000, fy: 5000, cx: 3000, cy: 2000}
//       # or: {width: 6000, height: 4000, horizontal_fov_deg: 62}
//       distortion: [k1, k2, p1, p2, k3]   # optional (OpenCV): the pipelines undistort the
//                                          #   frames onto the pinhole camera (sh: with the depth)
//       position_m: [12.0, -30.0, 1.6]
//       look_at_m: [0.0, 0.0, 5.0]         # or world_from_camera: [16 numbers, row-major]
//       up: [0, 0, 1]                      # optional, with look_at_m
//       reprojection_error_px: 0.4         # optional: from the calibration that gave it
//   objects:
//     - {name: building, kind: solid, mesh: building.obj}   # OBJ/PLY, relative to this file
//     - {name: site, kind: surface, mesh: scan.ply, frame: utm, offset: [739000, 4206000, 0]}
//                                          # offset: added to the file's vertices (a photogrammetry
//                                          #   export's georeferencing shift), in the entry's frame
//     - {name: ground, kind: surface, mesh: ground.ply}
//     - {name: dome, kind: sphere, center_m: [0, 0, 10], radius_m: 2}
//   known_albedo:                          # optional: materials whose reflectance is known
//     - {material: chart/white, albedo: [0.87, 0.87, 0.86]}
//   lamps:
//     - {name: key, type: point, intensity_w_sr: [30, 27, 22], position_m: [1, 2, 2.5]}
//     - name: track
//       type: spot
//       intensity_w_sr: [20, 20, 20]
//       direction: [0, 0, -1]
//       cone_half_angle_deg: 25
//       falloff_deg: 5
//       track: [{utc: "2026-01-15T19:00:00Z", position_m: [-2, -2, 2.9]}, ...]
//
// Materials: one per object (named after it) and, for an OBJ's `usemtl NAME` groups, one per
// group ("building/NAME"). A file's vertex or face colours are not albedo and are ignored.
// Positions in UTM are converted point by point through geodetic coordinates (GeographicLib),
// like `relume process --mesh` (meridian convergence and grid scale applied exactly); a
// world_from_camera given in UTM is rotated by the meridian convergence at the camera.
#pragma once

#include <Eigen/Core>
#include <string>

#include "core/scene_model.h"
#include "core/site.h"

namespace relume {

// Throws ConfigError naming the file, line and key for anything malformed or invalid, IoError
// for an unreadable file (this or a mesh it names). `session_site`: the site when the file
// gives none; a file whose site is more than 1 m from it is refused (the session's frames carry
// the sun for its own site).
SceneModel LoadSceneModelFile(const std::string& path, const Site& session_site);

// Where a mesh file's vertices are: `frame` "enu" (metres at the model's site) or "utm"
// (easting, northing, ellipsoidal height in `utm_zone`, 0 = the site's), after `offset` is added.
struct MeshPlacement {
  std::string frame = "enu";
  int utm_zone = 0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  bool IsValid(std::string* why) const;
};

// Adds the mesh file `mesh_path` (OBJ/PLY) to `model` as object `name` of `kind` (surface or
// solid), its vertices converted to ENU at model->site as the scene file's meshes are; one
// material named after the object and one per OBJ `usemtl` group. An object of the same name is
// replaced. Throws InvalidArgumentError for a bad placement or kind, ConfigError/IoError for the
// file.
void AddMeshObject(SceneModel* model, const std::string& name, SceneModelObject::Kind kind,
                   const std::string& mesh_path, const MeshPlacement& placement);

}  // namespace relume
