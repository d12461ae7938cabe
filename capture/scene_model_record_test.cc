#include "capture/scene_model_record.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "capture/session.h"
#include "core/error.h"

namespace relume::capture {
namespace {

SceneModel ExampleModel() {
  SceneModel model;
  model.source = "test";
  model.site = Site::FromDegrees(47.37689, 8.54169, 460.0);
  SceneModelCamera camera;
  camera.device_id = "sim:dslr";
  camera.camera = PinholeCamera::LookAt(PinholeIntrinsics::FromHorizontalFov(320, 240, 1.1),
                                        Eigen::Vector3d(1.0 / 3.0, -7.25, 1.6), Eigen::Vector3d(0.1, 0.2, 0.3));
  camera.distortion = {0.1, -0.02, 0.001, 0.0005, 0.0};
  camera.source = "chessboard";
  camera.reprojection_error_px = 0.31;
  model.cameras.push_back(camera);
  model.materials.push_back({"wall", std::nullopt});
  model.materials.push_back({"chart-patch", Eigen::Vector3d(0.1, 0.2, 0.3)});
  SceneModelObject wall;
  wall.name = "wall";
  wall.kind = SceneModelObject::Kind::kSurface;
  wall.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1.0 / 7.0}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  wall.face_material = {0, 1};
  model.objects.push_back(wall);
  SceneModelObject ball;
  ball.name = "ball";
  ball.kind = SceneModelObject::Kind::kSphere;
  ball.sphere_center = {0.5, 0.5, 0.25};
  ball.sphere_radius_m = 0.25;
  ball.material = 0;
  model.objects.push_back(ball);
  SceneModelLamp lamp;
  lamp.name = "spot";
  lamp.type = SceneModelLamp::Type::kSpot;
  lamp.intensity_w_sr = {30, 27, 22};
  lamp.direction = {0, 0, -1};
  lamp.cone_half_angle_rad = 0.5;
  lamp.falloff_rad = 0.1;
  const UtcTime t0 = ParseIso8601("2026-01-15T19:00:00Z").utc;
  lamp.track = {{t0, {-2, -2, 2.9}}, {t0 + std::chrono::seconds(60), {2, 2, 2.9}}};
  model.lamps.push_back(lamp);
  return model;
}

TEST(SceneModelRecordTest, RoundTripsExactly) {
  const SceneModel model = ExampleModel();
  const SceneModel back = SceneModelFromJson(SceneModelToJson(model), "row 1");
  EXPECT_EQ(SceneModelToJson(back), SceneModelToJson(model));
  ASSERT_EQ(back.cameras.size(), 1u);
  EXPECT_TRUE(back.cameras[0].camera.world_from_camera.isApprox(model.cameras[0].camera.world_from_camera, 0.0));
  EXPECT_EQ(back.cameras[0].distortion, model.cameras[0].distortion);
  EXPECT_EQ(back.objects[0].vertices[3], model.objects[0].vertices[3]);  // 1/7 survives exactly
  ASSERT_TRUE(back.materials[1].albedo.has_value());
  EXPECT_FALSE(back.materials[0].albedo.has_value());
  EXPECT_EQ(back.lamps[0].track[1].utc, model.lamps[0].track[1].utc);
  EXPECT_EQ(back.objects[1].kind, SceneModelObject::Kind::kSphere);
}

TEST(SceneModelRecordTest, LampPositionIsInterpolatedAndHeld) {
  const SceneModel model = ExampleModel();
  const SceneModelLamp& lamp = model.lamps[0];
  const UtcTime t0 = lamp.track[0].utc;
  EXPECT_TRUE(lamp.PositionAt(t0 - std::chrono::hours(1)).isApprox(Eigen::Vector3d(-2, -2, 2.9)));
  EXPECT_TRUE(lamp.PositionAt(t0 + std::chrono::seconds(15)).isApprox(Eigen::Vector3d(-1, -1, 2.9)));
  EXPECT_TRUE(lamp.PositionAt(t0 + std::chrono::hours(1)).isApprox(Eigen::Vector3d(2, 2, 2.9)));
}

TEST(SceneModelRecordTest, FindsCamerasByFullOrBareId) {
  const SceneModel model = ExampleModel();
  EXPECT_NE(model.FindCamera("sim:dslr"), nullptr);
  EXPECT_NE(model.FindCamera("dslr"), nullptr);
  EXPECT_EQ(model.FindCamera("rgbd"), nullptr);
}

TEST(SceneModelRecordTest, RefusesNewerVersionsAndInvalidModels) {
  nlohmann::json j = nlohmann::json::parse(SceneModelToJson(ExampleModel()));
  j["version"] = SceneModel::kVersion + 1;
  EXPECT_THROW(SceneModelFromJson(j.dump(), "row 3"), ConfigError);

  j = nlohmann::json::parse(SceneModelToJson(ExampleModel()));
  j["objects"][0]["face_material"] = {0, 7};
  try {
    SceneModelFromJson(j.dump(), "row 4");
    FAIL() << "an out-of-range material was accepted";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("row 4"), std::string::npos) << e.what();
  }
  EXPECT_THROW(SceneModelFromJson("{\"version\": 1}", "row 5"), IoError);
  EXPECT_THROW(SceneModelFromJson("not json", "row 6"), IoError);

  SceneModel model = ExampleModel();
  model.cameras[0].camera.world_from_camera.linear() *= 2.0;
  std::string why;
  EXPECT_FALSE(model.IsValid(&why));
  EXPECT_NE(why.find("rotation"), std::string::npos) << why;
}

TEST(SceneModelRecordTest, TheLatestRowApplies) {
  std::vector<CalibrationRecord> rows(3);
  rows[0].kind = kSceneModelKind;
  rows[0].id = 1;
  rows[1].kind = "response";
  rows[2].kind = kSceneModelKind;
  rows[2].id = 3;
  ASSERT_NE(LatestSceneModelRow(rows), nullptr);
  EXPECT_EQ(LatestSceneModelRow(rows)->id, 3);
  const std::vector<CalibrationRecord> none;
  EXPECT_EQ(LatestSceneModelRow(none), nullptr);
  EXPECT_EQ(DescribeSceneModel(ExampleModel()),
            "1 camera, 2 objects (2 triangles), 2 materials (1 with known albedo), 1 lamp");
}

}  // namespace
}  // namespace relume::capture
