#include "sim/world/scene_yaml.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/frames.h"

namespace relume::sim {
namespace {

class SceneYamlTest : public ::testing::Test {
 protected:
  std::string Write(const std::string& name, const std::string& text) {
    const auto path = std::filesystem::path(::testing::TempDir()) / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::string ErrorOf(const std::string& path) {
    try {
      LoadScene(path);
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  }
  static constexpr const char* kHeader =
      "site: {latitude_deg: 47.0, longitude_deg: 8.0}\n"
      "time: 2026-03-20T12:00:00Z\n";
};

TEST_F(SceneYamlTest, ReadsAMinimalScene) {
  const std::string path = Write("ok.yaml", std::string(kHeader) +
                                                "objects:\n"
                                                "  - name: ball\n"
                                                "    sphere: {center: [0, 0, 1], radius_m: 0.5}\n"
                                                "    albedo: [0.1, 0.2, 0.3]\n"
                                                "cameras:\n"
                                                "  - {name: c, hfov_deg: 60, eye: [0, -5, 1], target: [0, 0, 1]}\n");
  const Scene scene = LoadScene(path);
  EXPECT_EQ(scene.name, "ok");
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].shape, SceneObject::Shape::kSphere);
  EXPECT_DOUBLE_EQ(scene.objects[0].albedo.y(), 0.2);
  EXPECT_FALSE(scene.sun.enabled);  // no sun: section
  EXPECT_EQ(scene.cameras[0].camera.intrinsics.width, 640);
  EXPECT_NEAR(scene.site.latitude_deg(), 47.0, 1e-12);
}

TEST_F(SceneYamlTest, ErrorsNameFileLineAndKey) {
  const std::string bad_number =
      Write("a.yaml", std::string(kHeader) + "objects:\n  - name: b\n    sphere: {center: [0, 0, x], radius_m: 1}\n");
  EXPECT_EQ(ErrorOf(bad_number), bad_number + ":5: center: 'x' is not a finite number");

  const std::string typo = Write("b.yaml", std::string(kHeader) + "objects:\n  - name: b\n    albedoo: [1, 1, 1]\n");
  EXPECT_EQ(ErrorOf(typo).rfind(typo + ":5: albedoo: unknown key", 0), 0u) << ErrorOf(typo);

  const std::string albedo = Write(
      "c.yaml", std::string(kHeader) +
                    "objects:\n  - name: b\n    box: {center: [0, 0, 0], size: [1, 1, 1]}\n    albedo: [1.5, 0, 0]\n");
  EXPECT_EQ(ErrorOf(albedo),
            albedo + ":6: albedo: albedo must be in [0, 1] per channel (linear sRGB Lambertian reflectance)");

  const std::string time = Write("d.yaml", "site: {latitude_deg: 1, longitude_deg: 2}\ntime: 2026-03-20T12:00\n");
  EXPECT_EQ(ErrorOf(time).rfind(time + ":2: time: ", 0), 0u) << ErrorOf(time);

  const std::string missing_mesh =
      Write("e.yaml", std::string(kHeader) + "objects:\n  - name: m\n    mesh: {file: nothere.obj}\n");
  EXPECT_NE(ErrorOf(missing_mesh).find(":5: file: "), std::string::npos) << ErrorOf(missing_mesh);
  EXPECT_NE(ErrorOf(missing_mesh).find("nothere.obj"), std::string::npos);

  const std::string two_shapes =
      Write("f.yaml", std::string(kHeader) +
                          "objects:\n  - name: m\n    sphere: {center: [0, 0, 0], radius_m: 1}\n"
                          "    box: {center: [0, 0, 0], size: [1, 1, 1]}\n");
  EXPECT_NE(ErrorOf(two_shapes).find(":4: m: an object needs exactly one of"), std::string::npos)
      << ErrorOf(two_shapes);

  const std::string bad_zone = Write("g.yaml", std::string(kHeader) + "utm_zone: 61\nobjects: []\n");
  EXPECT_EQ(ErrorOf(bad_zone), bad_zone + ":3: utm_zone: expected a UTM zone number in 1..60");

  const std::string bad_sky = Write("h.yaml", std::string(kHeader) + "sky: {type: cloudy}\n");
  EXPECT_EQ(ErrorOf(bad_sky), bad_sky + ":3: type: unknown sky type 'cloudy'; expected black, uniform or gradient");

  EXPECT_NE(ErrorOf("/nonexistent/scene.yaml").find("/nonexistent/scene.yaml"), std::string::npos);
}

TEST_F(SceneYamlTest, UtmCoordinatesAreConvertedToTheSitesEnuFrame) {
  // Zone 32 at 47 N 8 E: grid north is turned by the meridian convergence, about
  // -(1 deg) * sin(47 deg) = -0.731 deg (west of true north), since the zone's central
  // meridian is 9 E.
  const Eigen::Vector3d site_in_grid =
      UtmGridFrame(Site::FromDegrees(47.0, 8.0), 32).GridFromGeodetic(Site::FromDegrees(47.0, 8.0));
  const std::string east = std::to_string(site_in_grid.x()), north = std::to_string(site_in_grid.y() + 10.0);
  const std::string path = Write("utm.yaml", std::string(kHeader) + "utm_zone: 32\n" +
                                                 "objects:\n"
                                                 "  - name: ball\n"
                                                 "    sphere: {center: [" +
                                                 east + ", " + north +
                                                 ", 0.0], radius_m: 1.0}\n"
                                                 "cameras:\n"
                                                 "  - {name: c, hfov_deg: 60, position: [" +
                                                 east + ", " + north +
                                                 ", 0.0],"
                                                 " quaternion_wxyz: [1, 0, 0, 0]}\n");
  const Scene scene = LoadScene(path);
  ASSERT_TRUE(scene.utm_zone.has_value());
  // 10 grid metres north of the site: about 10 m away, turned 0.73 deg west of true north.
  const Eigen::Vector3d ball = scene.objects[0].sphere_center;
  EXPECT_NEAR(ball.head<2>().norm(), 10.0 / UtmGridFrame(scene.site, 32).scale(), 1e-4);
  EXPECT_NEAR(RadToDeg(std::atan2(ball.x(), ball.y())), -0.7314, 0.01);
  EXPECT_NEAR(ball.z(), 0.0, 1e-4);
  const Eigen::Matrix3d r = scene.cameras[0].camera.world_from_camera.linear();
  // Grid x (east) in ENU: turned by the convergence about up.
  const double angle_deg = RadToDeg(std::atan2(r(1, 0), r(0, 0)));
  EXPECT_NEAR(angle_deg, 0.7314, 0.01);
}

}  // namespace
}  // namespace relume::sim
