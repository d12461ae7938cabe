// ChArUco intrinsics and a camera's pose from surveyed ArUco markers (calibration/intrinsics.h,
// calibration/markers.h) on images the simulator renders, against the true camera. Boards and
// markers are meshes of one quad per run of equal cells of OpenCV's own drawing (per-face albedo:
// black 0.05, white 0.85), so what the camera sees is exactly what would be printed. The renderer
// samples each pixel at its centre (no anti-aliasing): edges carry up to half a pixel of aliasing,
// which is the floor of both methods here.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/core.hpp>

#include "calibration/intrinsics.h"
#include "calibration/markers.h"
#include "calibration/rgbd_extrinsics.h"
#include "capture/rgbd_geometry.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"
#include "sim/devices/depth_model.h"
#include "sim/world/world.h"
#include "tests/apps/cli_runner.h"
#include "tests/calibration/eight_bit.h"

namespace relume::calibration {
namespace {

namespace fs = std::filesystem;

// `image` (8-bit grey, black < 128 <= white) as a mesh: pixel (u, v) covers top_left + [u, u+1)
// * right + [v, v+1) * down, facing down x right. One quad per horizontal run of equal pixels.
sim::TriangleMesh ImageMesh(const cv::Mat& image, const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
                            const Eigen::Vector3d& down) {
  sim::TriangleMesh mesh;
  for (int v = 0; v < image.rows; ++v) {
    int u0 = 0;
    for (int u = 1; u <= image.cols; ++u) {
      const bool white = image.at<std::uint8_t>(v, u0) >= 128;
      if (u < image.cols && (image.at<std::uint8_t>(v, u) >= 128) == white) continue;
      sim::TriangleMesh run = sim::MakeQuad(top_left + u0 * right + (v + 1) * down, (u - u0) * right, -down);
      run.face_albedo.assign(run.triangles.size(), Eigen::Vector3d::Constant(white ? 0.85 : 0.05));
      mesh.Append(run);
      u0 = u;
    }
  }
  return mesh;
}

sim::Scene SunlitScene(const std::string& name) {
  sim::Scene scene;
  scene.name = name;
  scene.site = Site::FromDegrees(47.37, 8.54, 400.0);
  scene.time = ParseIso8601("2026-06-21T10:00:00Z").utc;
  scene.sun.direction_in_enu = Eigen::Vector3d(0.3, -0.8, 0.5).normalized();
  scene.render.sun_samples = 1;
  scene.render.sky_samples = 4;
  return scene;
}

void AddPlane(sim::Scene* scene, const std::string& name, const Eigen::Vector3d& origin, const Eigen::Vector3d& u,
              const Eigen::Vector3d& v) {
  sim::SceneObject plane;
  plane.name = name;
  plane.shape = sim::SceneObject::Shape::kPlane;
  plane.albedo = Eigen::Vector3d::Constant(0.6);
  plane.mesh = sim::MakeQuad(origin, u, v);
  scene->objects.push_back(plane);
}

using testing::ToEightBit;

PinholeIntrinsics TrueIntrinsics() {
  return PinholeIntrinsics::FromHorizontalFov(640, 480, 60.0 * std::numbers::pi / 180.0);
}

// ---- ChArUco ------------------------------------------------------------------------------------

CharucoOptions Board() {
  CharucoOptions b;  // squares of 8 cells, markers of 6 (4 bits + border): whole cells when drawn
  b.squares_x = 7;
  b.squares_y = 5;
  b.square_m = 0.04;
  b.marker_m = 0.03;
  b.dictionary = "4x4_50";
  return b;
}

// The board in the x-z plane facing -y, its bottom-left corner at the origin, on a white margin.
sim::Scene CharucoScene() {
  sim::Scene scene = SunlitScene("charuco");
  const CharucoOptions b = Board();
  const cv::Mat drawn = DrawCharucoBoard(b, 8);  // one pixel per cell
  const double cell = b.square_m / 8.0;
  sim::SceneObject board;
  board.name = "board";
  board.shape = sim::SceneObject::Shape::kMesh;
  board.mesh = ImageMesh(drawn, Eigen::Vector3d(0, 0, b.squares_y * b.square_m), Eigen::Vector3d(cell, 0, 0),
                         Eigen::Vector3d(0, 0, -cell));
  scene.objects.push_back(board);
  sim::SceneObject margin;
  margin.name = "margin";
  margin.shape = sim::SceneObject::Shape::kPlane;
  margin.albedo = Eigen::Vector3d::Constant(0.85);
  margin.mesh =
      sim::MakeQuad(Eigen::Vector3d(-0.1, 0.001, -0.1), Eigen::Vector3d(0.48, 0, 0), Eigen::Vector3d(0, 0, 0.4));
  scene.objects.push_back(margin);
  return scene;
}

// Ten views: six of the whole board from around it and four close ones that show only a part of
// it, reaching the image's edges, which a chessboard calibration could not use.
std::vector<cv::Mat> CharucoViews(std::vector<bool>* whole) {
  const sim::World world(CharucoScene());
  const Eigen::Vector3d center(0.14, 0.0, 0.10);
  struct View {
    Eigen::Vector3d eye, target;
  };
  const std::vector<View> views = {
      {{0.14, -0.40, 0.12}, center},
      {{-0.05, -0.36, 0.18}, center},
      {{0.35, -0.33, 0.02}, center},
      {{0.10, -0.30, 0.35}, center},
      {{0.25, -0.45, -0.10}, center},
      {{0.00, -0.42, 0.00}, center},
      {{0.02, -0.21, 0.03}, {0.05, 0.0, 0.05}},
      {{0.27, -0.20, 0.18}, {0.24, 0.0, 0.15}},
      {{0.05, -0.19, 0.20}, {0.07, 0.0, 0.16}},
      {{0.26, -0.22, 0.01}, {0.23, 0.0, 0.04}},
  };
  std::vector<cv::Mat> images;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const PinholeCamera camera =
        PinholeCamera::LookAt(TrueIntrinsics(), views[i].eye, views[i].target, Eigen::Vector3d(0.04 * (i % 3), 0, 1));
    images.push_back(ToEightBit(world.Render(camera).radiance));
    // Whole: the board's four outer corners project into the image.
    const CharucoOptions b = Board();
    bool inside = true;
    for (const Eigen::Vector3d& corner : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(b.squares_x * b.square_m, 0, 0),
                                          Eigen::Vector3d(0, 0, b.squares_y * b.square_m),
                                          Eigen::Vector3d(b.squares_x * b.square_m, 0, b.squares_y * b.square_m)}) {
      const Eigen::Vector2d px = camera.intrinsics.Project(camera.world_from_camera.inverse() * corner);
      inside &= px.x() >= 0 && px.y() >= 0 && px.x() < camera.intrinsics.width && px.y() < camera.intrinsics.height;
    }
    whole->push_back(inside);
  }
  return images;
}

TEST(MarkersSimTest, CharucoViewsRecoverTheTrueIntrinsicsIncludingPartialViews) {
  const PinholeIntrinsics truth = TrueIntrinsics();
  std::vector<bool> whole;
  const std::vector<cv::Mat> images = CharucoViews(&whole);
  const IntrinsicsResult r = CalibrateIntrinsicsCharuco(images, Board());
  std::cout << "ChArUco: " << r.Report() << "; truth fx " << truth.fx << ", cx " << truth.cx << ", cy " << truth.cy
            << "\n";
  EXPECT_EQ(r.views_used.size(), images.size()) << r.Report();
  EXPECT_LT(r.rms_px, 0.5) << r.Report();
  EXPECT_NEAR(r.intrinsics.fx / truth.fx, 1.0, 0.01) << r.Report();
  EXPECT_NEAR(r.intrinsics.fy / truth.fy, 1.0, 0.01) << r.Report();
  EXPECT_NEAR(r.intrinsics.cx, truth.cx, 3.0) << r.Report();
  EXPECT_NEAR(r.intrinsics.cy, truth.cy, 3.0) << r.Report();

  // The four close views do not show the whole board: a chessboard calibration would drop them.
  EXPECT_EQ(std::count(whole.begin(), whole.end(), false), 4);

  // The wrong dictionary finds no board, and the message names what to check.
  CharucoOptions wrong = Board();
  wrong.dictionary = "5x5_50";
  try {
    CalibrateIntrinsicsCharuco(images, wrong);
    FAIL() << "a 5x5 board was found";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("only 0 of 10 images"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--dictionary"), std::string::npos) << e.what();
  }
  CharucoOptions bad = Board();
  bad.marker_m = 0.05;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("smaller than the square"), std::string::npos);
  bad = Board();
  bad.squares_x = 12;
  bad.squares_y = 10;  // 60 markers: more than 4x4_50 has
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("has 50"), std::string::npos) << why;
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180.0 / std::numbers::pi;
}

// ---- RGB-D extrinsics ---------------------------------------------------------------------------

// An RGB-D sensor whose depth camera (640x480, 58 deg) sits 25 mm beside its colour camera (640x480,
// 62.5 deg), slightly turned, looking at the ChArUco board from twelve tilts. Depth is the world's
// with Kinect-like noise and quantisation (sim/devices/depth_model.h), and without (`ideal`).
struct RgbdBoardViews {
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();  // colour from depth
  PinholeIntrinsics colour_k = PinholeIntrinsics::FromHorizontalFov(640, 480, 62.5 * std::numbers::pi / 180.0);
  PinholeIntrinsics depth_k = PinholeIntrinsics::FromHorizontalFov(640, 480, 58.0 * std::numbers::pi / 180.0);
  std::vector<cv::Mat> colour, depth, ideal;
};

RgbdBoardViews RenderRgbdBoardViews() {
  const sim::World world(CharucoScene());
  RgbdBoardViews v;
  v.truth.linear() = (Eigen::AngleAxisd(0.4 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()) *
                      Eigen::AngleAxisd(0.2 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitX()))
                         .toRotationMatrix();
  v.truth.translation() = Eigen::Vector3d(-0.025, 0.001, -0.002);
  const Eigen::Vector3d center(0.14, 0.0, 0.10);
  const std::vector<Eigen::Vector3d> eyes = {{-0.21, -0.50, 0.10}, {0.49, -0.50, 0.10},  {0.14, -0.48, 0.45},
                                             {0.14, -0.50, -0.22}, {0.39, -0.52, 0.35},  {-0.11, -0.55, -0.12},
                                             {-0.15, -0.45, 0.30}, {0.45, -0.45, -0.10}, {0.30, -0.40, 0.40},
                                             {-0.05, -0.60, 0.35}, {0.35, -0.58, -0.20}, {-0.20, -0.40, -0.05}};
  for (std::size_t i = 0; i < eyes.size(); ++i) {
    const PinholeCamera c = PinholeCamera::LookAt(v.colour_k, eyes[i], center, Eigen::Vector3d(0, 0, 1));
    PinholeCamera d;
    d.intrinsics = v.depth_k;
    d.world_from_camera = c.world_from_camera * v.truth;
    v.colour.push_back(ToEightBit(world.Render(c).radiance));
    const GroundTruth seen = world.Render(d);
    v.depth.push_back(sim::MeasureDepth(seen.depth_m, seen.normal_in_world, d, sim::DepthModelOptions(), 7 + i));
    v.ideal.push_back(seen.depth_m);
  }
  return v;
}

// The calibration starts from the identity, as for a sensor that reports no transform.
TEST(MarkersSimTest, RgbdExtrinsicsFromAChArUcoBoardSeenByBothCameras) {
  const RgbdBoardViews views = RenderRgbdBoardViews();
  const Eigen::Isometry3d& truth = views.truth;
  const PinholeIntrinsics& colour_k = views.colour_k;
  const PinholeIntrinsics& depth_k = views.depth_k;
  const std::vector<cv::Mat>& colour = views.colour;
  const std::vector<cv::Mat>& depth = views.depth;
  const std::vector<cv::Mat>& ideal = views.ideal;
  RgbdExtrinsicsOptions options;
  options.board = Board();
  const RgbdExtrinsicsResult r =
      CalibrateRgbdExtrinsics(colour, depth, colour_k, depth_k, Eigen::Isometry3d::Identity(), options);
  const double translation_error = (r.color_from_depth.translation() - truth.translation()).norm();
  const double rotation_error = AngleDeg(r.color_from_depth.linear(), truth.linear());
  std::cout << r.Report() << "\ntranslation error " << translation_error * 1e3 << " mm, rotation error "
            << rotation_error << " deg; plane RMS";
  for (double rms : r.view_plane_rms_m) std::cout << " " << rms * 1e3;
  std::cout << " mm\n";
  const RgbdExtrinsicsResult floor =
      CalibrateRgbdExtrinsics(colour, ideal, colour_k, depth_k, Eigen::Isometry3d::Identity(), options);
  std::cout << "ideal depth: translation error "
            << (floor.color_from_depth.translation() - truth.translation()).norm() * 1e3 << " mm, rotation error "
            << AngleDeg(floor.color_from_depth.linear(), truth.linear()) << " deg\n";
  EXPECT_EQ(r.views_used.size(), colour.size()) << r.Report();
  // Measured 2026-12-04: 2.03 mm and 0.149 deg with Kinect noise, 2.05 mm and 0.147 deg with the
  // ideal depth: the floor is the colour side, the board's pose from corners carrying the
  // renderer's aliasing (0.38 px RMS in the ChArUco calibration above); with six of the views it
  // was 3.6 mm and 0.22 deg, falling with the number of views.
  EXPECT_LT(translation_error, 0.003) << r.Report();
  EXPECT_LT(rotation_error, 0.2) << r.Report();

  // Without the tilts (three views from straight ahead) the translation is not determined: refused.
  const sim::World world(CharucoScene());
  const Eigen::Vector3d center(0.14, 0.0, 0.10);
  std::vector<cv::Mat> flat_colour, flat_depth;
  for (int i = 0; i < 3; ++i) {
    const PinholeCamera c = PinholeCamera::LookAt(colour_k, Eigen::Vector3d(0.14 + 0.01 * i, -0.5 - 0.05 * i, 0.10),
                                                  center, Eigen::Vector3d(0, 0, 1));
    PinholeCamera d;
    d.intrinsics = depth_k;
    d.world_from_camera = c.world_from_camera * truth;
    flat_colour.push_back(ToEightBit(world.Render(c).radiance));
    flat_depth.push_back(world.Render(d).depth_m);
  }
  try {
    CalibrateRgbdExtrinsics(flat_colour, flat_depth, colour_k, depth_k, Eigen::Isometry3d::Identity(), options);
    FAIL() << "boards at one tilt were accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("tilt the board differently"), std::string::npos) << e.what();
  }
}

// The CLI: the board frames of a sensor that reports no transform, in a session as recorded
// (depth in millimetres, unregistered); `calibrate rgbd` stores the geometry row processing uses.
TEST(MarkersSimTest, TheCliStoresAnRgbdSensorsTransformAsItsGeometry) {
  const RgbdBoardViews views = RenderRgbdBoardViews();
  const fs::path dir = testing::FreshTempDir("markers", "rgbd");
  const fs::path session = dir / "session";
  {
    capture::SessionInfo info;
    info.name = "rgbd board";
    info.site = Site::FromDegrees(47.37, 8.54, 400.0);
    info.created_utc = ParseIso8601("2026-06-21T10:00:00Z").utc;
    auto writer = capture::SessionWriter::Create(session, info);
    for (std::size_t i = 0; i < views.colour.size(); ++i) {
      drivers::RgbdFrame f;
      f.device_id = "import:k2";
      f.color.pixels = views.colour[i];
      f.color.layout = ColorLayout::kRgb;
      f.color.bits_per_sample = 8;
      f.color.white_level = 255;
      f.depth_m = views.depth[i];
      f.color_intrinsics = views.colour_k;
      f.depth_intrinsics = views.depth_k;
      f.registered_to_color = false;  // and no transform: the identity
      f.depth_timing.host_utc = f.color_timing.host_utc = info.created_utc + std::chrono::seconds(2 * i);
      writer->WriteRgbdFrame(f);
    }
  }
  const testing::CliResult wrong =
      testing::RunRelume("calibrate rgbd --session " + session.string() + " --device import:k2 --dictionary 5x5_50");
  EXPECT_NE(wrong.exit_code, 0);
  EXPECT_NE(wrong.output.find("only 0 of 12 frame pairs"), std::string::npos) << wrong.output;
  const testing::CliResult r = testing::RunRelume("calibrate rgbd --session " + session.string() +
                                                  " --device import:k2 --charuco 7x5 --square 0.04 --marker 0.03");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const capture::SessionReader reader(session);
  const std::vector<capture::CalibrationRecord> rows = reader.Calibrations();
  std::int64_t first_depth = 0;
  for (const capture::FrameRecord& f : reader.Frames()) {
    if (f.stream == "depth" && first_depth == 0) first_depth = f.id;
  }
  const capture::CalibrationRecord* row = capture::RgbdGeometryAt(rows, "import:k2", first_depth);
  ASSERT_NE(row, nullptr);
  drivers::RgbdFrame geometry;
  capture::ApplyRgbdGeometryJson(row->json, &geometry);
  const double translation_error = (geometry.color_from_depth.translation() - views.truth.translation()).norm();
  const double rotation_error = AngleDeg(geometry.color_from_depth.linear(), views.truth.linear());
  std::cout << r.output << "stored: translation error " << translation_error * 1e3 << " mm, rotation error "
            << rotation_error << " deg\n";
  // Depth stored in whole millimetres, as sensors deliver it: about as close as the library test.
  EXPECT_LT(translation_error, 0.003) << r.output;
  EXPECT_LT(rotation_error, 0.2) << r.output;
  EXPECT_FALSE(geometry.registered_to_color);
  EXPECT_EQ(geometry.depth_intrinsics.width, 640);
  // The row keeps the residuals of the calibration that gave it.
  const nlohmann::json stored = nlohmann::json::parse(row->json);
  EXPECT_EQ(stored["calibration"]["plane_rms_m"].size(), 12u) << stored.dump();
  fs::remove_all(dir);
}

// ---- surveyed markers ---------------------------------------------------------------------------

struct PlacedMarker {
  int id;
  Eigen::Vector3d top_left, right, down;  // per pixel of a 6-pixel drawing (one per cell)
};

// A courtyard corner: a wall (y = 2, facing -y) and the ground, with 0.2 m markers of 4x4_50 on
// both, their corners known in ENU.
std::vector<PlacedMarker> Markers() {
  const double cell = 0.2 / 6.0;
  const Eigen::Vector3d wall_right(cell, 0, 0), wall_down(0, 0, -cell);
  const Eigen::Vector3d ground_right(cell, 0, 0), ground_down(0, -cell, 0);
  return {{3, {-0.9, 1.999, 1.5}, wall_right, wall_down},     {7, {0.1, 1.999, 1.2}, wall_right, wall_down},
          {11, {1.0, 1.999, 1.5}, wall_right, wall_down},     {20, {-0.5, 1.0, 0.001}, ground_right, ground_down},
          {21, {0.9, 1.4, 0.001}, ground_right, ground_down}, {30, {0.1, 0.9, 0.001}, ground_right, ground_down}};
}

sim::Scene MarkerScene() {
  sim::Scene scene = SunlitScene("markers");
  AddPlane(&scene, "ground", Eigen::Vector3d(-3, -2, 0), Eigen::Vector3d(6, 0, 0), Eigen::Vector3d(0, 4, 0));
  AddPlane(&scene, "wall", Eigen::Vector3d(-3, 2, 0), Eigen::Vector3d(0, 0, 3), Eigen::Vector3d(6, 0, 0));
  for (const PlacedMarker& m : Markers()) {
    sim::SceneObject o;
    o.name = "marker" + std::to_string(m.id);
    o.shape = sim::SceneObject::Shape::kMesh;
    o.mesh = ImageMesh(DrawMarker("4x4_50", m.id, 6), m.top_left, m.right, m.down);
    scene.objects.push_back(o);
  }
  return scene;
}

PinholeCamera MarkerCamera() {
  return PinholeCamera::LookAt(TrueIntrinsics(), Eigen::Vector3d(0.3, -1.2, 1.3), Eigen::Vector3d(0.2, 1.5, 0.5),
                               Eigen::Vector3d(0, 0, 1));
}

// The surveyed file: every marker's corners in ENU, in the printed order (top-left first).
void WriteMarkerFile(const fs::path& path, const std::vector<int>& leave_out = {}) {
  std::ofstream out(path);
  out << std::setprecision(12) << "id,corner,e,n,u\n";
  for (const PlacedMarker& m : Markers()) {
    if (std::find(leave_out.begin(), leave_out.end(), m.id) != leave_out.end()) continue;
    const Eigen::Vector3d c[4] = {m.top_left, m.top_left + 6 * m.right, m.top_left + 6 * m.right + 6 * m.down,
                                  m.top_left + 6 * m.down};
    for (int k = 0; k < 4; ++k)
      out << m.id << "," << k << "," << c[k].x() << "," << c[k].y() << "," << c[k].z() << "\n";
  }
}

TEST(MarkersSimTest, SurveyedMarkersGiveTheCamerasPoseInTheSiteFrame) {
  const sim::World world(MarkerScene());
  const PinholeCamera truth = MarkerCamera();
  const cv::Mat image = ToEightBit(world.Render(truth).radiance);
  const std::vector<MarkerDetection> found = DetectMarkers(image, "4x4_50");
  ASSERT_EQ(found.size(), Markers().size()) << "every marker is in view";

  // Detected corners against the true projections of the surveyed corners.
  const fs::path dir = testing::FreshTempDir("markers", "pose");
  WriteMarkerFile(dir / "markers.csv", {30});
  const std::vector<SurveyedMarker> surveyed = LoadMarkerFile((dir / "markers.csv").string(), "enu", Site());
  ASSERT_EQ(surveyed.size(), 5u);
  std::vector<int> unsurveyed;
  const std::vector<GroundControlPoint> points = MarkerControlPoints(found, surveyed, &unsurveyed);
  ASSERT_EQ(points.size(), 20u);
  EXPECT_EQ(unsurveyed, std::vector<int>{30});
  double worst = 0.0;
  for (const GroundControlPoint& p : points) {
    const Eigen::Vector2d expected = truth.intrinsics.Project(truth.world_from_camera.inverse() * p.enu_m);
    worst = std::max(worst, (expected - p.pixel).norm());
  }
  // Measured: 1.65 px at worst, on a ground marker seen 35 deg from its plane (one ray per pixel,
  // no anti-aliasing); the wall markers are within a few tenths.
  EXPECT_LT(worst, 2.0) << "a detected corner is more than 2 px from its true projection";

  const CameraPoseResult pose = EstimateCameraPose(points, truth.intrinsics);
  const double position_error = (pose.world_from_camera.translation() - truth.world_from_camera.translation()).norm();
  const double angle_error = AngleDeg(pose.world_from_camera.linear(), truth.world_from_camera.linear());
  std::cout << "markers: worst corner " << worst << " px, pose RMS " << pose.rms_px << " px, position "
            << position_error * 1000 << " mm, rotation " << angle_error << " deg\n";
  // Measured 2026-12-04: RMS 0.59 px, 3.3 mm and 0.03 deg with the camera 2-3.5 m from the markers.
  EXPECT_EQ(pose.inliers, 20);
  EXPECT_LT(pose.rms_px, 1.0);
  EXPECT_LT(position_error, 0.01) << "1 cm at 2-3.5 m";
  EXPECT_LT(angle_error, 0.1);
  fs::remove_all(dir);
}

TEST(MarkersSimTest, MarkerFilesWithMistakesAreRefusedNamingTheLine) {
  const fs::path dir = testing::FreshTempDir("markers", "files");
  const auto refused = [&](const std::string& text, const std::string& expected) {
    std::ofstream(dir / "m.csv") << text;
    try {
      LoadMarkerFile((dir / "m.csv").string(), "enu", Site());
      ADD_FAILURE() << "accepted: " << text;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused("id,corner,e,n,u\n1,0,0,0,0\n1,1,1,0,0\n1,2,1,0,-1\n", "marker 1 has no corner 3");
  refused("id,corner,e,n,u\n1,0,0,0,0\n1,0,1,0,0\n", "is also on line 2");
  refused("id,corner,e,n,u\n1,4,0,0,0\n", "corner 4 is not 0..3");
  refused("id,corner,e,n,u\n1,0,0,0\n", "m.csv:2: marker: expected id,corner,a,b,c");
  refused("id,corner,e,n,u\n", "no surveyed marker corners");
  EXPECT_THROW(DetectMarkers(cv::Mat::zeros(10, 10, CV_8UC1), "3x3_9"), InvalidArgumentError);
  fs::remove_all(dir);
}

// The CLI path for a real camera: ChArUco frames and one frame of the surveyed markers imported
// into a session; `calibrate intrinsics --charuco` gives the scene model's camera, `calibrate pose
// --markers` its pose in the site frame, both against the truth.
TEST(MarkersSimTest, TheCliCalibratesFromAChArUcoSeriesThenPosesFromMarkers) {
  const fs::path dir = testing::FreshTempDir("markers", "cli");
  const fs::path session = dir / "session";
  std::vector<bool> whole;
  std::vector<cv::Mat> images = CharucoViews(&whole);
  images.push_back(ToEightBit(sim::World(MarkerScene()).Render(MarkerCamera()).radiance));
  {
    capture::SessionInfo info;
    info.name = "markers";
    info.site = Site::FromDegrees(47.37, 8.54, 400.0);
    info.created_utc = ParseIso8601("2026-06-21T10:00:00Z").utc;
    auto writer = capture::SessionWriter::Create(session, info);
    int i = 0;
    for (const cv::Mat& image : images) {
      drivers::StillFrame frame;
      frame.device_id = "import:cam";
      frame.image.pixels = image;
      frame.timing.host_utc = info.created_utc + std::chrono::seconds(i++);
      writer->WriteStillFrame(frame);
    }
  }
  const testing::CliResult intrinsics = testing::RunRelume("calibrate intrinsics --session " + session.string() +
                                                           " --frames 1-10 --charuco 7x5 --square 0.04 --marker 0.03");
  ASSERT_EQ(intrinsics.exit_code, 0) << intrinsics.output;
  EXPECT_NE(intrinsics.output.find("over 10 views"), std::string::npos) << intrinsics.output;

  WriteMarkerFile(dir / "markers.csv", {30});
  const testing::CliResult wrong =
      testing::RunRelume("calibrate pose --session " + session.string() + " --device import:cam --markers " +
                         (dir / "markers.csv").string() + " --dictionary 6x6_50");
  EXPECT_NE(wrong.exit_code, 0);
  EXPECT_NE(wrong.output.find("check --dictionary"), std::string::npos) << wrong.output;
  const testing::CliResult pose =
      testing::RunRelume("calibrate pose --session " + session.string() + " --device import:cam --markers " +
                         (dir / "markers.csv").string());
  ASSERT_EQ(pose.exit_code, 0) << pose.output;
  EXPECT_NE(pose.output.find("frame 11: 5 of 5 surveyed markers found; ids not in"), std::string::npos) << pose.output;
  const std::optional<SceneModel> model = capture::LatestSceneModel(session);
  ASSERT_TRUE(model && model->FindCamera("import:cam"));
  const SceneModelCamera& camera = *model->FindCamera("import:cam");
  ASSERT_TRUE(camera.has_pose);
  const PinholeCamera truth = MarkerCamera();
  EXPECT_NEAR(camera.camera.intrinsics.fx / truth.intrinsics.fx, 1.0, 0.01);
  // ChArUco intrinsics (fx -0.05 %, cx +2.7 px) and 20 corners. Measured 2026-12-04: 8.3 mm and
  // 0.17 deg, against 3.3 mm and 0.03 deg with the true intrinsics (the test above).
  const double position_error =
      (camera.camera.world_from_camera.translation() - truth.world_from_camera.translation()).norm();
  std::cout << "CLI: position " << position_error * 1000 << " mm, rotation "
            << AngleDeg(camera.camera.world_from_camera.linear(), truth.world_from_camera.linear()) << " deg\n"
            << camera.source << "\n";
  EXPECT_LT(position_error, 0.02) << pose.output;
  EXPECT_LT(AngleDeg(camera.camera.world_from_camera.linear(), truth.world_from_camera.linear()), 0.3);
  EXPECT_NE(camera.source.find("ChArUco views"), std::string::npos) << camera.source;
  EXPECT_NE(camera.source.find("corners of surveyed markers"), std::string::npos) << camera.source;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::calibration
