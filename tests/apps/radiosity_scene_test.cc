// The radiosity pipeline's view of a sim world's scene model (pipeline/radiosity_scene.h): patch
// orientation, the pixel -> patch map against the renderer's object ids, and lamps over time.
#include "pipeline/radiosity_scene.h"

#include <gtest/gtest.h>

#include <set>

#include "core/error.h"
#include "rig/scene_model_from_rig.h"
#include "sim/world/scene_yaml.h"

namespace relume::pipeline {
namespace {

sim::Scene Room() {
  return sim::LoadScene(std::string(RELUME_SOURCE_DIR) + "/config/scenes/indoor-room.yaml");
}

// What capture stores for the room (rig/scene_model_from_rig.h), lamps tracked over 10 minutes.
SceneModel Model(const sim::Scene& scene) {
  return rig::SceneModelFromSimScene(scene, "test", scene.time - std::chrono::minutes(1),
                                     scene.time + std::chrono::minutes(10));
}

TEST(RadiositySceneTest, RoomPlanesFaceInwardAndBoxesOutward) {
  const sim::Scene scene = Room();
  const RadiosityScene rs = RadiositySceneFromModel(Model(scene));
  std::string why;
  ASSERT_TRUE(rs.mesh.IsValid(&why)) << why;
  ASSERT_EQ(rs.object_triangles.size(), scene.objects.size());
  const Eigen::Vector3d room_center(0, 0, 1.5);
  int t = 0;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    Eigen::Vector3d object_center = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& v : scene.objects[o].mesh.vertices) object_center += v;
    object_center /= static_cast<double>(scene.objects[o].mesh.vertices.size());
    for (int k = 0; k < rs.object_triangles[o]; ++k, ++t) {
      const Eigen::Vector3d a = rs.mesh.Corner(t, 0), b = rs.mesh.Corner(t, 1), c = rs.mesh.Corner(t, 2);
      const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
      const Eigen::Vector3d centroid = (a + b + c) / 3.0;
      if (scene.objects[o].shape == sim::SceneObject::Shape::kPlane) {
        EXPECT_GT(normal.dot(room_center - centroid), 0.0) << scene.objects[o].name;
      } else {
        EXPECT_GT(normal.dot(centroid - object_center), 0.0) << scene.objects[o].name;
        EXPECT_FALSE(normal.z() < -0.99 && centroid.z() < 1e-3) << scene.objects[o].name << ": face on the floor kept";
      }
    }
  }
  EXPECT_EQ(t, rs.mesh.TriangleCount());
  // Boxes standing on the floor (legs, cabinet) lost their bottoms: 10 triangles, not 12.
  EXPECT_EQ(rs.object_triangles[scene.ObjectIndex("cabinet")], 10);
  EXPECT_EQ(rs.object_triangles[scene.ObjectIndex("monitor")], 12);
  // Materials: one per object, or one per group; never the scene's albedo.
  EXPECT_EQ(rs.mesh.materials.size(), scene.objects.size());
  const RadiosityScene grouped = RadiositySceneFromModel(Model(scene), "wall-west+wall-east,wall-south+wall-north");
  EXPECT_EQ(grouped.mesh.materials.size(), scene.objects.size() - 2);
  EXPECT_EQ(grouped.object_material[scene.ObjectIndex("wall-west")],
            grouped.object_material[scene.ObjectIndex("wall-east")]);
  for (const radiosity::Material& m : grouped.mesh.materials) EXPECT_EQ(m.albedo, radiosity::Rgb::Constant(0.5));
  EXPECT_THROW(RadiositySceneFromModel(Model(scene), "wall-west+sofa"), InvalidArgumentError);
}

// The test room with its chart (tests/data/scenes/indoor-room-bounces.yaml): the chart's faces
// carry 25 scene model materials (frame + 24 patches), and the radiosity scene keeps them apart;
// the patches' reference albedo is known, the frame's and the room's are not.
TEST(RadiositySceneTest, AChartKeepsOneMaterialPerPatchWithItsKnownAlbedo) {
  const sim::Scene scene =
      sim::LoadScene(std::string(RELUME_SOURCE_DIR) + "/tests/data/scenes/indoor-room-bounces.yaml");
  const SceneModel model = Model(scene);
  const RadiosityScene rs = RadiositySceneFromModel(model, "wall-west+wall-east");
  const int chart = scene.ObjectIndex("chart");
  ASSERT_GE(chart, 0);
  ASSERT_EQ(rs.triangle_object.size(), static_cast<std::size_t>(rs.mesh.TriangleCount()));
  ASSERT_EQ(rs.triangle_face.size(), rs.triangle_object.size());
  ASSERT_EQ(rs.known_albedo.size(), rs.mesh.materials.size());
  std::set<int> chart_materials;
  int known = 0;
  for (int t = 0; t < rs.mesh.TriangleCount(); ++t) {
    const int o = rs.triangle_object[t];
    const int m = rs.mesh.geometry.material[static_cast<std::size_t>(t)];
    // Each triangle's material is its scene model face's.
    const SceneModelObject& object = model.objects[o];
    const int face_material = object.face_material[rs.triangle_face[t]];
    if (o == chart) {
      chart_materials.insert(m);
      EXPECT_EQ(rs.mesh.materials[m].name, model.materials[face_material].name);
      EXPECT_EQ(rs.known_albedo[m].has_value(), model.materials[face_material].albedo.has_value());
      if (rs.known_albedo[m]) {
        EXPECT_EQ(*rs.known_albedo[m], *model.materials[face_material].albedo);
        // The reference value is the simulated chart's own face albedo.
        EXPECT_LT((*rs.known_albedo[m] - scene.objects[chart].mesh.face_albedo[rs.triangle_face[t]]).norm(), 1e-12);
      }
    } else {
      EXPECT_FALSE(rs.known_albedo[m].has_value()) << rs.mesh.materials[m].name;
    }
  }
  for (const auto& a : rs.known_albedo) known += a.has_value() ? 1 : 0;
  EXPECT_EQ(chart_materials.size(), 25u);  // the frame and 24 patches
  EXPECT_EQ(known, 24);
  // Groups still merge whole objects.
  EXPECT_EQ(rs.object_material[scene.ObjectIndex("wall-west")], rs.object_material[scene.ObjectIndex("wall-east")]);
}

TEST(RadiositySceneTest, PixelPatchesLieOnTheObjectTheRendererHits) {
  sim::Scene scene = Room();
  const RadiosityScene rs = RadiositySceneFromModel(Model(scene));
  radiosity::HierarchyOptions options;
  options.max_patch_edge_m = 0.5;
  const radiosity::PatchHierarchy h(rs.mesh, options);
  const RayCaster caster(rs.mesh.geometry);
  // Every leaf's centroid maps back to that leaf.
  for (int p = 0; p < h.LeafCount(); ++p) ASSERT_EQ(PatchAt(h, h.leaf(p).root, h.leaf(p).centroid), p);

  scene.render.indirect_bounces = 0;
  const sim::World world(scene);
  const PinholeCamera camera = world.Camera("door", 160, 120);
  const cv::Mat ids = PatchIdImage(h, caster, camera);
  const sim::GroundTruth truth = world.Render(camera);
  std::vector<int> object_of_material(rs.mesh.materials.size());
  for (size_t o = 0; o < scene.objects.size(); ++o) object_of_material[rs.object_material[o]] = static_cast<int>(o);
  int agree = 0, total = 0;
  for (int y = 0; y < ids.rows; ++y) {
    for (int x = 0; x < ids.cols; ++x) {
      const int id = ids.at<int>(y, x);
      const int object = truth.object_id.at<int>(y, x);
      if (object < 0) continue;
      ++total;
      if (id >= 0 && object_of_material[h.leaf(id).material] == object) ++agree;
    }
  }
  EXPECT_EQ(total, ids.rows * ids.cols);                              // a closed room: every pixel sees a surface
  EXPECT_GT(agree, total - total / 200) << agree << " of " << total;  // all but coplanar contact seams
}

TEST(RadiositySceneTest, LampsMoveAndSpotsKeepTheirCone) {
  const sim::World world(Room());
  const UtcTime t0 = world.scene().time;
  const radiosity::Lighting at0 = LightingAt(Model(world.scene()), t0);
  const radiosity::Lighting at60 = LightingAt(Model(world.scene()), t0 + std::chrono::seconds(60));
  ASSERT_EQ(at0.point_lights.size(), 2u);
  EXPECT_TRUE(at0.point_lights[0].position_m.isApprox(Eigen::Vector3d(0, 0, 2.8)));
  EXPECT_EQ(at0.point_lights[0].spot_direction.norm(), 0.0);
  EXPECT_TRUE(at0.point_lights[1].position_m.isApprox(Eigen::Vector3d(-2, -2, 2.9)));
  EXPECT_TRUE(at60.point_lights[1].position_m.isApprox(Eigen::Vector3d(2, 1.5, 2.9)));
  EXPECT_NEAR(at0.point_lights[1].cone_half_angle_rad, 25.0 * std::numbers::pi / 180.0, 1e-12);
  std::string why;
  EXPECT_TRUE(at0.IsValid(&why)) << why;
}

}  // namespace
}  // namespace relume::pipeline
