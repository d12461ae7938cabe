// What processing knows of a session's scene: the cameras (intrinsics, lens distortion and pose),
// the geometry (objects as triangles with a material per face), the materials (names, and the
// reflectance where it is known, e.g. a ColorChecker's patches), the lamps (stated intensity and
// where they stood when) and the site. A session stores it as a calibration row of kind
// "scene_model" (capture/scene_model_record.h): capture writes one for simulated rigs from their
// world, calibration and import write one for real rigs. Pipelines read the scene from here and
// nowhere else; a simulator's world is only ever compared against.
//
// Conventions:
//  - Positions are metres in the site's local East-North-Up frame (core/frames.h): x east,
//    y north, z up. Poses are target_from_source (core/pinhole.h: world_from_camera).
//  - An object is one surface or solid of the scene. Kind says how its triangles face:
//    kSurface, an open surface seen from inside the scene (a wall, a floor, the ground; its
//    triangles may wind either way); kSolid, a closed object seen from outside (a box, a
//    photogrammetry mesh of a building); kSphere, a sphere given by centre and radius (no
//    triangles). Objects are static: only lamps move.
//  - Materials are Lambertian; `albedo` is the diffuse reflectance (linear sRGB, [0, 1]) where
//    it is known independently of the session's photographs (a chart's reference values), and
//    empty where processing has to estimate it. A simulated world's true albedo is never written
//    here.
//  - Lamps: intensity in W/sr per channel as the lamp's maker or a photometric calibration
//    states it; `track` is where the lamp stood when (UTC), linearly interpolated between
//    entries and held before the first and after the last.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/pinhole.h"
#include "core/site.h"
#include "core/time.h"

namespace relume {

// An RGB-D device's camera is its colour camera (registered depth lies in its frame). Its
// intrinsics here are for one image size; processing takes those of the size a frame was
// recorded at from the session (rgbd_geometry rows) and the pose from here.
struct SceneModelCamera {
  std::string device_id;  // the session device it describes ("sim:dslr", "gphoto2:...")
  PinholeCamera camera;   // intrinsics and world_from_camera (ENU at the site)
  // OpenCV's model (k1, k2, p1, p2[, k3]); empty: no distortion (or already undistorted).
  std::vector<double> distortion;
  std::string source;  // where the pose and intrinsics came from ("simulated rig 'x'", "chessboard ...")
  double reprojection_error_px = -1.0;  // RMS of the calibration that gave them; < 0: not measured

  bool IsValid(std::string* why) const;
};

struct SceneModelMaterial {
  std::string name;
  std::optional<Eigen::Vector3d> albedo;  // known reflectance, linear sRGB in [0, 1]; empty: unknown
};

struct SceneModelObject {
  enum class Kind { kSurface, kSolid, kSphere };
  std::string name;
  Kind kind = Kind::kSolid;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;                   // vertex indices
  std::vector<int> face_material;                           // per triangle: index into SceneModel::materials
  Eigen::Vector3d sphere_center = Eigen::Vector3d::Zero();  // kSphere
  double sphere_radius_m = 0.0;                             // kSphere
  int material = -1;                                        // kSphere: its material (index into SceneModel::materials)
};
const char* ToString(SceneModelObject::Kind kind);
// "surface", "solid" or "sphere"; throws InvalidArgumentError otherwise.
SceneModelObject::Kind SceneModelObjectKindFromString(const std::string& text);

struct LampPose {
  UtcTime utc{};
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

struct SceneModelLamp {
  enum class Type { kPoint, kSpot };
  std::string name;
  Type type = Type::kPoint;
  Eigen::Vector3d intensity_w_sr = Eigen::Vector3d::Zero();
  // Spots: full intensity within cone_half_angle_rad - falloff_rad of `direction`, falling
  // smoothly (smoothstep) to 0 at cone_half_angle_rad.
  Eigen::Vector3d direction = -Eigen::Vector3d::UnitZ();
  double cone_half_angle_rad = 0.0;
  double falloff_rad = 0.0;
  std::vector<LampPose> track;  // in time order; at least one entry

  bool IsValid(std::string* why) const;
  // Where the lamp stood at `utc` (see the top of this file).
  Eigen::Vector3d PositionAt(UtcTime utc) const;
};

struct SceneModel {
  static constexpr int kVersion = 1;  // of the stored form (capture/scene_model_record.h)

  std::string source;  // what wrote it: "simulated rig 'sim-outdoor' (its world, scene.yaml)", ...
  Site site;
  std::vector<SceneModelCamera> cameras;
  std::vector<SceneModelMaterial> materials;
  std::vector<SceneModelObject> objects;
  std::vector<SceneModelLamp> lamps;

  // False (with the reason) for invalid cameras or lamps, out-of-range indices, non-finite
  // positions, a material index per triangle missing, or two cameras for one device.
  bool IsValid(std::string* why) const;
  // The camera of a session device: its full id ("sim:dslr") or the id alone ("dslr"); null when
  // the model has none.
  const SceneModelCamera* FindCamera(const std::string& device_id) const;
  // -1 when absent.
  int ObjectIndex(const std::string& name) const;
  std::size_t TriangleCount() const;
};

}  // namespace relume
