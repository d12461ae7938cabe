#include "core/scene_model_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "core/error.h"
#include "core/frames.h"

namespace relume {
namespace {

namespace fs = std::filesystem;

class SceneModelFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relume-scene-model-file-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "box.obj")
        << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl white\nf 1 3 4\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& text) {
    const fs::path path = dir_ / "scene.yaml";
    std::ofstream(path) << text;
    return path.string();
  }
  fs::path dir_;
  const Site site_ = Site::FromDegrees(37.9715, 23.7267, 110.0);
};

TEST_F(SceneModelFileTest, ReadsCamerasObjectsMaterialsAndLamps) {
  const SceneModel model = LoadSceneModelFile(Write(R"(
cameras:
  - device: gphoto2:canon
    intrinsics: {width: 600, height: 400, fx: 500, fy: 500, cx: 300, cy: 200}
    position_m: [10, -20, 1.5]
    look_at_m: [0, 0, 1.5]
objects:
  - {name: box, kind: solid, mesh: box.obj}
  - {name: ball, kind: sphere, center_m: [0, 0, 5], radius_m: 2}
known_albedo:
  - {material: box/white, albedo: [0.8, 0.8, 0.8]}
lamps:
  - {name: key, intensity_w_sr: [30, 27, 22], position_m: [1, 2, 2.5]}
  - name: track
    type: spot
    intensity_w_sr: [20, 20, 20]
    direction: [0, 0, -1]
    cone_half_angle_deg: 25
    falloff_deg: 5
    track: [{utc: "2026-01-15T19:00:00Z", position_m: [-2, -2, 2.9]}, {utc: "2026-01-15T19:01:00Z", position_m: [2, 2, 2.9]}]
)"),
                                              site_);
  std::string why;
  ASSERT_TRUE(model.IsValid(&why)) << why;
  ASSERT_EQ(model.cameras.size(), 1u);
  const PinholeCamera& camera = model.cameras[0].camera;
  // The look-at point projects to the principal point.
  const Eigen::Vector3d in_camera = camera.world_from_camera.inverse() * Eigen::Vector3d(0, 0, 1.5);
  const Eigen::Vector2d pixel = camera.intrinsics.Project(in_camera);
  EXPECT_NEAR(pixel.x(), 300.0, 1e-9);
  EXPECT_NEAR(pixel.y(), 200.0, 1e-9);
  EXPECT_TRUE(camera.world_from_camera.translation().isApprox(Eigen::Vector3d(10, -20, 1.5)));
  // Materials: the object's, then its OBJ groups; only the given one has a known albedo.
  ASSERT_EQ(model.objects.size(), 2u);
  EXPECT_EQ(model.objects[0].face_material.size(), 2u);
  EXPECT_EQ(model.materials[model.objects[0].face_material[0]].name, "box/red");
  EXPECT_FALSE(model.materials[model.objects[0].face_material[0]].albedo.has_value());
  EXPECT_EQ(model.materials[model.objects[0].face_material[1]].name, "box/white");
  EXPECT_TRUE(model.materials[model.objects[0].face_material[1]].albedo->isApprox(Eigen::Vector3d::Constant(0.8)));
  EXPECT_EQ(model.objects[1].kind, SceneModelObject::Kind::kSphere);
  // The spot half way along its track.
  ASSERT_EQ(model.lamps.size(), 2u);
  const UtcTime half = ParseIso8601("2026-01-15T19:00:30Z").utc;
  EXPECT_TRUE(model.lamps[1].PositionAt(half).isApprox(Eigen::Vector3d(0, 0, 2.9)));
  EXPECT_NEAR(model.lamps[1].cone_half_angle_rad, 25.0 * std::numbers::pi / 180.0, 1e-12);
}

TEST_F(SceneModelFileTest, UtmPositionsGoThroughGeodeticCoordinates) {
  // The site's own grid coordinates, and a point 100 m grid-east and 3 m up of it.
  const UtmGridFrame grid(site_);
  const Eigen::Vector3d origin = grid.GridFromGeodetic(site_);
  std::ofstream obj(dir_ / "utm.obj");
  obj << std::setprecision(17) << "v " << origin.x() << " " << origin.y() << " " << origin.z() << "\nv "
      << origin.x() + 100 << " " << origin.y() << " " << origin.z() + 3 << "\nv " << origin.x() << " "
      << origin.y() + 100 << " " << origin.z() << "\nf 1 2 3\n";
  obj.close();
  char text[512];
  std::snprintf(text, sizeof(text), "frame: utm\nobjects:\n  - {name: ground, kind: surface, mesh: utm.obj}\n");
  const SceneModel model = LoadSceneModelFile(Write(text), site_);
  const SceneModelObject& ground = model.objects.at(0);
  EXPECT_LT(ground.vertices[0].norm(), 1e-6);  // the site is the ENU origin
  const EnuFrame enu(site_);
  const Eigen::Vector3d expected = enu.EnuFromGeodetic(grid.GeodeticFromGrid(origin + Eigen::Vector3d(100, 0, 3)));
  EXPECT_LT((ground.vertices[1] - expected).norm(), 1e-9);
  // Grid east is not true east: the meridian convergence turns it (about 0.4 deg here).
  const double bearing_deg = std::atan2(ground.vertices[1].x(), ground.vertices[1].y()) * 180.0 / std::numbers::pi;
  EXPECT_GT(std::abs(bearing_deg - 90.0), 0.1);
  EXPECT_LT(std::abs(bearing_deg - 90.0), 3.0);
}

// A photogrammetry export: vertices relative to a georeferencing shift given as `offset` (scene
// file) or MeshPlacement (session add-scene-model --mesh): the same ENU vertices as a mesh written
// in full UTM coordinates.
TEST_F(SceneModelFileTest, AMeshWithAGeoreferencingOffsetLandsWhereItsFullCoordinatesDo) {
  const UtmGridFrame grid(site_);
  const Eigen::Vector3d origin = grid.GridFromGeodetic(site_);
  const Eigen::Vector3d shift(std::floor(origin.x()) - 20.0, std::floor(origin.y()) + 35.0, 100.0);
  std::ofstream full(dir_ / "full.obj"), local(dir_ / "local.obj");
  full << std::setprecision(17);
  local << std::setprecision(17);
  const Eigen::Vector3d corners[3] = {origin, origin + Eigen::Vector3d(40, 0, 2), origin + Eigen::Vector3d(0, 30, 1)};
  for (const Eigen::Vector3d& c : corners) {
    full << "v " << c.x() << " " << c.y() << " " << c.z() << "\n";
    const Eigen::Vector3d l = c - shift;
    local << "v " << l.x() << " " << l.y() << " " << l.z() << "\n";
  }
  full << "f 1 2 3\n";
  local << "usemtl stone\nf 1 2 3\n";
  full.close();
  local.close();
  char text[512];
  std::snprintf(text, sizeof(text),
                "frame: utm\nobjects:\n  - {name: full, kind: surface, mesh: full.obj}\n"
                "  - {name: local, kind: surface, mesh: local.obj, offset: [%.3f, %.3f, %.3f]}\n",
                shift.x(), shift.y(), shift.z());
  const SceneModel model = LoadSceneModelFile(Write(text), site_);
  ASSERT_EQ(model.objects.size(), 2u);
  for (std::size_t v = 0; v < 3; ++v) {
    EXPECT_LT((model.objects[0].vertices[v] - model.objects[1].vertices[v]).norm(), 1e-6) << v;
  }

  // The same through AddMeshObject, into a model that has the site only; then replaced by name.
  SceneModel added;
  added.site = site_;
  MeshPlacement placement;
  placement.frame = "utm";
  placement.offset = shift;
  AddMeshObject(&added, "scan", SceneModelObject::Kind::kSurface, (dir_ / "local.obj").string(), placement);
  ASSERT_EQ(added.objects.size(), 1u);
  for (std::size_t v = 0; v < 3; ++v) {
    EXPECT_LT((added.objects[0].vertices[v] - model.objects[0].vertices[v]).norm(), 1e-6) << v;
  }
  EXPECT_EQ(added.materials[static_cast<std::size_t>(added.objects[0].face_material[0])].name, "scan/stone");
  std::string why;
  EXPECT_TRUE(added.IsValid(&why)) << why;
  AddMeshObject(&added, "scan", SceneModelObject::Kind::kSolid, (dir_ / "full.obj").string(), {"utm", 0, {}});
  ASSERT_EQ(added.objects.size(), 1u);
  EXPECT_EQ(added.objects[0].kind, SceneModelObject::Kind::kSolid);
  EXPECT_THROW(
      AddMeshObject(&added, "x", SceneModelObject::Kind::kSurface, (dir_ / "full.obj").string(), {"gps", 0, {}}),
      InvalidArgumentError);
}

TEST_F(SceneModelFileTest, MistakesNameTheKey) {
  const auto message = [&](const std::string& text) -> std::string {
    try {
      LoadSceneModelFile(Write(text), site_);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message("cameras:\n  - {device: a, intrinsics: {width: 10, height: 10, horizontal_fov_deg: 60}, "
                    "position_m: [0, 0, 0], look_at_m: [1, 0, 0], lookat: [1, 1, 1]}\n")
                .find("lookat"),
            std::string::npos);
  EXPECT_NE(message("site: {latitude_deg: 38.0, longitude_deg: 23.7267}\n").find("from the session's site"),
            std::string::npos);
  EXPECT_NE(message("objects:\n  - {name: box, kind: solid, mesh: box.obj}\nknown_albedo:\n  - {material: box/blue, "
                    "albedo: [1, 1, 1]}\n")
                .find("box/blue"),
            std::string::npos);
  EXPECT_NE(message("objects:\n  - {name: box, kind: cube, mesh: box.obj}\n").find("cube"), std::string::npos);
  EXPECT_NE(message("objects:\n  - {name: box, kind: solid, mesh: missing.obj}\n").find("missing.obj"),
            std::string::npos);
  EXPECT_NE(message("lamps:\n  - {name: a, intensity_w_sr: [1, 1, -1], position_m: [0, 0, 1]}\n").find("intensity"),
            std::string::npos);
}

}  // namespace
}  // namespace relume
