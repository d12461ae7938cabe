// calibration/intrinsics.h on chessboard images rendered by the simulator (a board of 9 x 6
// inner corners, 25 mm squares, on a white margin, lit by the sun) from eight poses, against the
// camera's true intrinsics. The renderer samples each pixel at its centre (no anti-aliasing), so
// corners carry up to half a pixel of aliasing: the method's floor here is not zero.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <opencv2/core.hpp>

#include "calibration/intrinsics.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"
#include "sim/world/world.h"
#include "tests/apps/cli_runner.h"
#include "tests/calibration/eight_bit.h"

namespace relume::calibration {
namespace {

namespace fs = std::filesystem;

constexpr double kSquare = 0.025;

// The board in the x-z plane facing -y, its first inner corner at the origin.
sim::Scene BoardScene() {
  sim::Scene scene;
  scene.name = "chessboard";
  scene.site = Site::FromDegrees(47.37, 8.54, 400.0);
  scene.time = ParseIso8601("2026-06-21T10:00:00Z").utc;
  scene.sun.direction_in_enu = Eigen::Vector3d(0.3, -0.8, 0.5).normalized();
  scene.render.sun_samples = 1;
  scene.render.sky_samples = 4;
  sim::SceneObject board;
  board.name = "board";
  board.shape = sim::SceneObject::Shape::kMesh;
  for (int r = -1; r < 6; ++r) {
    for (int c = -1; c < 9; ++c) {
      sim::TriangleMesh square = sim::MakeQuad(Eigen::Vector3d(c * kSquare, 0.0, r * kSquare),
                                               Eigen::Vector3d(kSquare, 0, 0), Eigen::Vector3d(0, 0, kSquare));
      square.face_albedo.assign(square.triangles.size(), Eigen::Vector3d::Constant((r + c) % 2 == 0 ? 0.05 : 0.85));
      board.mesh.Append(square);
    }
  }
  scene.objects.push_back(board);
  sim::SceneObject margin;  // white paper around the board, 1 mm behind it
  margin.name = "margin";
  margin.shape = sim::SceneObject::Shape::kPlane;
  margin.albedo = Eigen::Vector3d::Constant(0.85);
  margin.mesh = sim::MakeQuad(Eigen::Vector3d(-3 * kSquare, 0.001, -3 * kSquare), Eigen::Vector3d(14 * kSquare, 0, 0),
                              Eigen::Vector3d(0, 0, 11 * kSquare));
  scene.objects.push_back(margin);
  return scene;
}

using testing::ToEightBit;

PinholeIntrinsics TrueIntrinsics() {
  return PinholeIntrinsics::FromHorizontalFov(640, 480, 55.0 * std::numbers::pi / 180.0);
}

// Eight poses around the board (left/right, up/down, near/far), looking at points near its centre.
std::vector<cv::Mat> BoardViews() {
  const sim::World world(BoardScene());
  const Eigen::Vector3d center(4 * kSquare, 0.0, 2.5 * kSquare);
  const std::vector<Eigen::Vector3d> eyes = {{0.10, -0.45, 0.06}, {-0.15, -0.40, 0.10}, {0.30, -0.35, 0.00},
                                             {0.05, -0.30, 0.25}, {0.20, -0.50, -0.10}, {-0.05, -0.38, -0.05},
                                             {0.35, -0.42, 0.20}, {0.00, -0.55, 0.15}};
  std::vector<cv::Mat> images;
  for (std::size_t i = 0; i < eyes.size(); ++i) {
    const Eigen::Vector3d target = center + Eigen::Vector3d(0.01 * static_cast<double>(i % 3), 0.0, 0.0);
    const PinholeCamera camera =
        PinholeCamera::LookAt(TrueIntrinsics(), eyes[i], target, Eigen::Vector3d(0.05 * (i % 2), 0, 1));
    images.push_back(ToEightBit(world.Render(camera).radiance));
  }
  return images;
}

TEST(IntrinsicsSimTest, ChessboardViewsRecoverTheTrueIntrinsics) {
  const PinholeIntrinsics truth = TrueIntrinsics();
  const std::vector<cv::Mat> images = BoardViews();
  const std::vector<Eigen::Vector3d> eyes(images.size());
  ChessboardOptions options;
  options.inner_cols = 9;
  options.inner_rows = 6;
  options.square_m = kSquare;
  const IntrinsicsResult r = CalibrateIntrinsics(images, options);
  EXPECT_EQ(r.views_used.size(), eyes.size()) << r.Report();
  // Measured 2026-12-03: fx 616.7 (truth 614.71, +0.3 %), fy 615.8, cx 321.5 (320.0), cy 238.7
  // (240.0), RMS 0.36 px: the corners' aliasing (one ray per pixel) is the floor here.
  EXPECT_LT(r.rms_px, 0.5) << r.Report();
  EXPECT_NEAR(r.intrinsics.fx / truth.fx, 1.0, 0.01) << r.Report() << " truth fx " << truth.fx;
  EXPECT_NEAR(r.intrinsics.fy / truth.fy, 1.0, 0.01) << r.Report();
  EXPECT_NEAR(r.intrinsics.cx, truth.cx, 3.0) << r.Report() << " truth cx " << truth.cx;
  EXPECT_NEAR(r.intrinsics.cy, truth.cy, 3.0) << r.Report() << " truth cy " << truth.cy;

  // A board given with the wrong corner count is found in no image, and the message says so.
  ChessboardOptions wrong = options;
  wrong.inner_cols = 10;
  try {
    CalibrateIntrinsics(images, wrong);
    FAIL() << "a 10 x 6 board was found";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("only 0 of 8 images"), std::string::npos) << e.what();
  }
}

// The CLI path: chessboard frames stored in a session, `relume calibrate intrinsics` puts the
// camera in the session's scene model without a pose, the pipelines then refuse it naming
// `calibrate pose`, and `calibrate pose` gives it one with those intrinsics.
TEST(IntrinsicsSimTest, TheCliStoresIntrinsicsThenAPoseInTheSceneModel) {
  const fs::path dir = testing::FreshTempDir("intrinsics", "cli");
  const fs::path session = dir / "session";
  {
    capture::SessionInfo info;
    info.name = "chessboard";
    info.site = BoardScene().site;
    info.created_utc = BoardScene().time;
    auto writer = capture::SessionWriter::Create(session, info);
    int i = 0;
    for (const cv::Mat& image : BoardViews()) {
      drivers::StillFrame frame;
      frame.device_id = "import:cam";
      frame.image.pixels = image;
      frame.timing.host_utc = info.created_utc + std::chrono::seconds(i++);
      writer->WriteStillFrame(frame);
    }
  }
  // The room's geometry and lamp first (a scene file), then the camera's intrinsics join them.
  std::ofstream(dir / "wall.obj") << "v -1 0.2 -1\nv 2 0.2 -1\nv 2 0.2 2\nv -1 0.2 2\nf 1 2 3\nf 1 3 4\n";
  std::ofstream(dir / "scene.yaml")
      << "objects:\n  - {name: wall, kind: surface, mesh: wall.obj}\n"
         "lamps:\n  - {name: lamp, intensity_w_sr: [10, 10, 10], position_m: [0, -1, 1]}\n";
  ASSERT_EQ(
      testing::RunRelume("session add-scene-model " + session.string() + " --from " + (dir / "scene.yaml").string())
          .exit_code,
      0);
  const testing::CliResult intrinsics = testing::RunRelume("calibrate intrinsics --session " + session.string() +
                                                           " --frames import:cam:still --board 9x6 --square 0.025");
  ASSERT_EQ(intrinsics.exit_code, 0) << intrinsics.output;
  EXPECT_NE(intrinsics.output.find("over 8 views"), std::string::npos) << intrinsics.output;
  std::optional<SceneModel> model = capture::LatestSceneModel(session);
  ASSERT_TRUE(model && model->FindCamera("import:cam"));
  EXPECT_FALSE(model->FindCamera("import:cam")->has_pose);
  EXPECT_EQ(model->objects.size(), 1u);  // the scene file's wall and lamp stay
  EXPECT_EQ(model->lamps.size(), 1u);
  EXPECT_NEAR(model->FindCamera("import:cam")->camera.intrinsics.fx, TrueIntrinsics().fx, 0.01 * TrueIntrinsics().fx);
  EXPECT_NE(testing::RunRelume("session info " + session.string()).output.find("NO POSE"), std::string::npos);
  const testing::CliResult refused =
      testing::RunRelume("process " + session.string() + " --pipeline radiosity --out " + (dir / "out").string());
  EXPECT_NE(refused.output.find("calibrate pose"), std::string::npos) << refused.output;

  // Ground control points on the board (its corners, in ENU), marked exactly in the first view.
  const PinholeCamera first =
      PinholeCamera::LookAt(TrueIntrinsics(), Eigen::Vector3d(0.10, -0.45, 0.06),
                            Eigen::Vector3d(4 * kSquare, 0.0, 2.5 * kSquare), Eigen::Vector3d(0, 0, 1));
  std::ofstream gcp(dir / "gcp.csv");
  gcp << std::setprecision(12) << "name,u,v,e,n,u\n";
  for (int r = 0; r < 6; r += 5) {
    for (int c = 0; c < 9; c += 4) {
      const Eigen::Vector3d p(c * kSquare, 0.0, r * kSquare);
      const Eigen::Vector2d px = first.intrinsics.Project(first.world_from_camera.inverse() * p);
      gcp << "c" << r << c << "," << px.x() << "," << px.y() << "," << p.x() << "," << p.y() << "," << p.z() << "\n";
    }
  }
  gcp.close();
  const testing::CliResult pose = testing::RunRelume("calibrate pose --session " + session.string() +
                                                     " --device import:cam --gcp " + (dir / "gcp.csv").string());
  ASSERT_EQ(pose.exit_code, 0) << pose.output;
  model = capture::LatestSceneModel(session);
  const SceneModelCamera* camera = model->FindCamera("import:cam");
  ASSERT_NE(camera, nullptr);
  EXPECT_TRUE(camera->has_pose);
  // The chessboard's intrinsics (0.3 % off in fx) and six points: the position to a few mm at 0.45 m.
  EXPECT_LT((camera->camera.world_from_camera.translation() - first.world_from_camera.translation()).norm(), 0.01)
      << pose.output;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume::calibration
