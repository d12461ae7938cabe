// The description of a simulated scene: geometry, materials, motions, lights, cameras and the
// render knobs. A Scene is plain data: LoadScene() (scene_yaml.h) builds one from a YAML file,
// tests build or edit one in code, and World (world.h) renders it.
//
// Conventions:
//  - Positions are metres in the scene frame, the site's local East-North-Up frame
//    (core/frames.h): x east, y north, z up. Scene files in UTM are converted on load.
//  - Materials are Lambertian (ideal diffuse): albedo is the diffuse reflectance per channel,
//    linear sRGB (core/color.h), in [0, 1]. Radiance leaving a surface is albedo * E / pi.
//  - Surfaces are two-sided: the normal used for shading faces the viewer. A point on a
//    surface sees only the half-space its facing normal points into.
//  - Motions are rigid translations of a whole object (or of a lamp), functions of the time
//    since Scene::time (the reference instant). At the reference time every object is where
//    its description puts it.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh_io.h"
#include "core/pinhole.h"
#include "core/site.h"
#include "core/sun/sun_position.h"
#include "core/time.h"
#include "sim/world/sky.h"

namespace relume::sim {

// Triangles in the scene frame (core/mesh_io.h); their colours are albedo. Albedo sources,
// first found wins: per-vertex (interpolated), per-face, the object's albedo.
using TriangleMesh = ::relume::MeshData;

// A rigid translation over time. OffsetAt(t, anchor) is how far an object whose reference
// point is `anchor` has moved from its described place at time t.
struct Motion {
  enum class Type {
    kStatic,
    kLinear,    // offset = velocity * dt
    kCircular,  // the anchor turns about the axis through `center` at 2 pi / period_s rad/s
                // (counter-clockwise seen from the tip of `axis`)
    kPath,      // the anchor follows waypoints (seconds after the reference, position),
                // linearly interpolated, held before the first and after the last
  };
  struct Waypoint {
    double t_s = 0.0;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
  };
  Type type = Type::kStatic;
  UtcTime reference_time{};  // dt = t - reference_time
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double period_s = 60.0;
  std::vector<Waypoint> waypoints;

  bool IsStatic() const { return type == Type::kStatic; }
  bool IsValid(std::string* why) const;
  Eigen::Vector3d OffsetAt(UtcTime time, const Eigen::Vector3d& anchor) const;
};
const char* ToString(Motion::Type type);

// The 24 patches of a ColorChecker as placed in the scene (at the object's reference place).
struct ColorCheckerLayout {
  std::vector<std::string> names;                 // reading order, dark skin .. black
  std::vector<Eigen::Vector3d> albedo;            // linear sRGB, clamped to [0, 1]
  std::vector<Eigen::Vector3d> centers_in_world;  // patch centres
  std::vector<Eigen::Vector3d> corners_in_world;  // 4 per patch: top-left, top-right, bottom-right, bottom-left
  Eigen::Vector3d normal_in_world = Eigen::Vector3d::UnitY();
  double patch_size_m = 0.0;
};

struct SceneObject {
  enum class Shape { kPlane, kBox, kSphere, kMesh, kColorChecker };
  std::string name;
  Shape shape = Shape::kMesh;
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.5);
  TriangleMesh mesh;                                        // every shape but spheres
  Eigen::Vector3d sphere_center = Eigen::Vector3d::Zero();  // spheres
  double sphere_radius_m = 0.0;
  std::optional<ColorCheckerLayout> colorchecker;  // kColorChecker
  Motion motion;

  // The point motions act on: the sphere's centre, or the centre of the mesh's bounding box.
  Eigen::Vector3d Anchor() const;
  bool IsValid(std::string* why) const;
};
const char* ToString(SceneObject::Shape shape);

// Builders for the primitive shapes (all produce triangles in the scene frame).
// A parallelogram origin + s * edge_u + t * edge_v, s, t in [0, 1]; normal edge_u x edge_v.
TriangleMesh MakeQuad(const Eigen::Vector3d& origin, const Eigen::Vector3d& edge_u, const Eigen::Vector3d& edge_v);
// A box with edges along east/north/up, turned by yaw_rad about up (counter-clockwise from above).
TriangleMesh MakeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size_m, double yaw_rad);

struct ColorCheckerGeometry {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();  // the side the patches face
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();      // toward the chart's top (row 1)
  double patch_size_m = 0.04;
  double gap_m = 0.0065;           // between patches
  double border_m = 0.011;         // frame around the patch grid
  double patch_offset_m = 0.0005;  // patches stand this far in front of the frame
  Eigen::Vector3d frame_albedo = Eigen::Vector3d::Constant(0.03);
};
// Builds the chart (black frame + 24 patches, per-face albedo) and its layout from reference
// patches (linear sRGB albedo; negative values, e.g. cyan's R = -0.044, are clamped to 0 and
// values above 1 to 1, since no surface reflects less than nothing).
SceneObject MakeColorChecker(const std::string& name, const ColorCheckerGeometry& geometry,
                             const std::vector<std::string>& patch_names,
                             const std::vector<Eigen::Vector3d>& patch_linear_rgb);

struct SunLight {
  bool enabled = true;
  Eigen::Vector3d irradiance_w_m2{1000.0, 980.0, 950.0};  // on a surface facing the sun
  double angular_diameter_rad = DegToRad(0.53);
  // When set, the sun stands in this direction (unit, ENU, toward the sun) at every time;
  // otherwise its direction follows the site and time (core/sun/sun_position.h).
  std::optional<Eigen::Vector3d> direction_in_enu;
  SunOptions sun_options;  // refraction settings for ComputeSunPosition
};

struct Lamp {
  enum class Type { kPoint, kSpot };
  std::string name;
  Type type = Type::kPoint;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d intensity_w_sr = Eigen::Vector3d::Constant(100.0);
  // Spots: full intensity within cone_half_angle_rad - falloff_rad of `direction`, a smooth
  // (smoothstep) fall to 0 at cone_half_angle_rad.
  Eigen::Vector3d direction = -Eigen::Vector3d::UnitZ();
  double cone_half_angle_rad = DegToRad(30.0);
  double falloff_rad = DegToRad(5.0);
  std::map<std::string, Eigen::Vector3d> named_positions;  // choose with Scene::SetLampPosition
  Motion motion;

  bool IsValid(std::string* why) const;
  // 1 inside the cone, 0 outside, smooth in between; 1 everywhere for point lamps.
  double SpotFactor(const Eigen::Vector3d& direction_from_lamp) const;
};

struct SceneCamera {
  std::string name;
  PinholeCamera camera;
  double horizontal_fov_rad = 0.0;
};

// The render's quality knobs (docs/sim-world.md measures their cost and error).
struct RenderOptions {
  int sun_samples = 8;        // points on the sun's disk (1 = hard shadows)
  int sky_samples = 32;       // cosine-weighted hemisphere rays for the sky's irradiance
  int indirect_bounces = 0;   // diffuse interreflection depth (0 = direct light only)
  int indirect_samples = 16;  // first-bounce rays per pixel when indirect_bounces > 0
  std::uint64_t seed = 1;     // fixes the indirect estimate's quasi-random sequence
  int threads = 2;            // row-parallel rendering threads

  bool IsValid(std::string* why) const;
};

struct Scene {
  std::string name;
  std::string source_path;  // the YAML file, when loaded from one
  Site site;
  UtcTime time{};               // the default instant, and motions' reference
  std::optional<int> utm_zone;  // the zone the file's coordinates were in, when UTM
  std::vector<SceneObject> objects;
  SunLight sun;
  Sky sky;
  std::vector<Lamp> lamps;
  std::vector<SceneCamera> cameras;
  RenderOptions render;

  bool IsValid(std::string* why) const;
  // Moves lamp `lamp_name` to its named position `position_name` (InvalidArgumentError
  // listing what exists when either is unknown).
  void SetLampPosition(const std::string& lamp_name, const std::string& position_name);
  int ObjectIndex(const std::string& object_name) const;  // -1 when absent
};

}  // namespace relume::sim
