#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "tests/apps/cli_runner.h"

namespace relume {
namespace {

namespace fs = std::filesystem;

TEST(SessionCliTest, VerifyRecoverInfo) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("session_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  {
    capture::SessionInfo info;
    info.name = "cli";
    info.site = Site::FromDegrees(37.97, 23.72, 150);
    info.created_utc = ParseIso8601("2026-06-21T06:00:00Z").utc;
    auto writer = capture::SessionWriter::Create(dir, info);
    drivers::StillFrame frame;
    frame.device_id = "sim:cam";
    frame.image.pixels = cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
    frame.timing.host_utc = info.created_utc;
    writer->WriteStillFrame(frame);
    writer->BeginBracket("sim:cam", info.created_utc, 3);  // left open, as after a crash
  }
  std::ofstream(dir / "frames" / "sim_cam" / "00000002_still.png.tmp") << "half";

  testing::CliResult verify = testing::RunRelume("session verify " + dir.string());
  EXPECT_EQ(verify.exit_code, 1) << verify.output;
  EXPECT_NE(verify.output.find("PROBLEMS: 1 frames checked"), std::string::npos) << verify.output;
  EXPECT_NE(verify.output.find("run `relume session recover`"), std::string::npos) << verify.output;

  const testing::CliResult recover = testing::RunRelume("session recover " + dir.string());
  EXPECT_EQ(recover.exit_code, 0) << recover.output;
  EXPECT_NE(recover.output.find("1 temporary files removed"), std::string::npos) << recover.output;

  verify = testing::RunRelume("session verify " + dir.string());
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_NE(verify.output.find("OK: 1 frames checked"), std::string::npos) << verify.output;

  const testing::CliResult info = testing::RunRelume("session info " + dir.string());
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("sim:cam still: 1"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("1 partial"), std::string::npos) << info.output;

  const testing::CliResult missing = testing::RunRelume("session info /nonexistent/session");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("relume: error: /nonexistent/session: no session here"), std::string::npos)
      << missing.output;
}

// `session add-scene-model --mesh`: a photogrammetry export with a UTM georeferencing shift joins
// the session's scene model (AddMeshObject, tested in core/scene_model_file_test.cc); a second
// mesh joins the first; bad flags are named.
TEST(SessionCliTest, AddSceneModelTakesAMeshWithItsGeoreferencingOffset) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("session_cli_mesh_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  {
    capture::SessionInfo info;
    info.name = "mesh";
    info.site = Site::FromDegrees(37.9715, 23.7267, 110.0);
    info.created_utc = ParseIso8601("2026-06-21T06:00:00Z").utc;
    auto writer = capture::SessionWriter::Create(dir / "session", info);
  }
  // Vertices relative to (739000, 4206000, 100) in UTM zone 34, about 500 m from the site.
  std::ofstream(dir / "scan.obj") << "v 0 0 0\nv 10 0 0\nv 0 10 1\nf 1 2 3\n";
  std::ofstream(dir / "wall.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                     "end_header\n0 0 0\n1 0 0\n0 0 1\n3 0 1 2\n";
  const std::string session = (dir / "session").string();
  testing::CliResult r =
      testing::RunRelume("session add-scene-model " + session + " --mesh " + (dir / "scan.obj").string() +
                         " --kind surface --mesh-frame utm --offset 739000,4206000,100");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = testing::RunRelume("session add-scene-model " + session + " --mesh " + (dir / "wall.ply").string() +
                         " --name wall");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 objects"), std::string::npos) << r.output;
  const std::optional<SceneModel> model = capture::LatestSceneModel(dir / "session");
  ASSERT_TRUE(model);
  ASSERT_EQ(model->objects.size(), 2u);
  EXPECT_EQ(model->objects[0].name, "scan");
  EXPECT_EQ(model->objects[0].kind, SceneModelObject::Kind::kSurface);
  const double distance = model->objects[0].vertices[0].norm();
  EXPECT_GT(distance, 100.0) << "the offset moved the scan from the site's origin";
  EXPECT_LT(distance, 2000.0);
  EXPECT_EQ(model->objects[1].name, "wall");
  r = testing::RunRelume("session add-scene-model " + session + " --mesh " + (dir / "scan.obj").string() +
                         " --offset 1,2");
  EXPECT_NE(r.exit_code, 0);
  r = testing::RunRelume("session add-scene-model " + session + " --mesh " + (dir / "scan.obj").string() +
                         " --mesh-frame gps");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("frame 'gps' is not enu or utm"), std::string::npos) << r.output;
  fs::remove_all(dir);
}

// `relume session import`'s flags reach the library and its errors reach the user (the import
// itself is tested in capture/import_test.cc): a JPEG without EXIF is refused, naming the file
// and what it lacks, and nothing is created; a malformed --tz is refused naming the flag.
TEST(SessionCliTest, ImportRefusesFilesWithoutTheirTimeAndBadFlags) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("session_import_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "card");
  cv::imwrite((dir / "card" / "IMG_0001.JPG").string(), cv::Mat(8, 8, CV_8UC3, cv::Scalar(10, 20, 30)));
  const std::string base = "session import " + (dir / "card").string() + " --out " + (dir / "s").string() + " --site " +
                           RELUME_SOURCE_DIR + "/config/sites/athens-acropolis.yaml";
  const testing::CliResult no_time = testing::RunRelume(base + " --tz +03:00");
  EXPECT_NE(no_time.exit_code, 0);
  EXPECT_NE(no_time.output.find("IMG_0001.JPG: its EXIF has no DateTimeOriginal"), std::string::npos) << no_time.output;
  EXPECT_FALSE(fs::exists(dir / "s"));
  const testing::CliResult bad_tz = testing::RunRelume(base + " --tz 3h");
  EXPECT_NE(bad_tz.exit_code, 0);
  EXPECT_NE(bad_tz.output.find("--tz 3h: expected an offset from UTC"), std::string::npos) << bad_tz.output;
  const testing::CliResult no_site =
      testing::RunRelume("session import " + (dir / "card").string() + " --out " + (dir / "s").string());
  EXPECT_NE(no_site.exit_code, 0);
  EXPECT_NE(no_site.output.find("--site"), std::string::npos) << no_site.output;
  fs::remove_all(dir);
}

// `relume session import --rgbd`: the flags reach capture::ImportRgbd (tested in
// capture/import_rgbd_test.cc) and its errors reach the user; `session info` shows the device.
TEST(SessionCliTest, ImportsAnRgbdRecordingAndNamesWhatIsMissing) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("session_import_rgbd_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "rec" / "rgb");
  fs::create_directories(dir / "rec" / "depth");
  std::ofstream rgb(dir / "rec" / "rgb.txt"), depth(dir / "rec" / "depth.txt");
  for (int k = 0; k < 3; ++k) {
    const std::string name = std::to_string(k) + ".png";
    cv::imwrite((dir / "rec" / "rgb" / name).string(), cv::Mat(12, 16, CV_8UC3, cv::Scalar(10, 20, 30 + k)));
    cv::imwrite((dir / "rec" / "depth" / name).string(), cv::Mat(12, 16, CV_16UC1, cv::Scalar(1200 + k)));
    rgb << "1773999000." << 100 + 33 * k << " rgb/" << name << "\n";
    depth << "1773999000." << 100 + 33 * k << " depth/" << name << "\n";
  }
  rgb.close();
  depth.close();
  const std::string base = "session import --rgbd " + (dir / "rec").string() + " --out " + (dir / "s").string() +
                           " --site " + RELUME_SOURCE_DIR + "/config/sites/athens-acropolis.yaml";
  const testing::CliResult no_intrinsics = testing::RunRelume(base);
  EXPECT_NE(no_intrinsics.exit_code, 0);
  EXPECT_NE(no_intrinsics.output.find("--rgbd needs --intrinsics fx,fy,cx,cy"), std::string::npos)
      << no_intrinsics.output;
  EXPECT_FALSE(fs::exists(dir / "s"));
  const testing::CliResult both = testing::RunRelume(base + " " + (dir / "rec").string() + " --intrinsics 20,20,8,6");
  EXPECT_NE(both.exit_code, 0);
  EXPECT_NE(both.output.find("give one of image files or folders, --rgbd DIR or --oni FILE"), std::string::npos)
      << both.output;

  const testing::CliResult oni_without_start =
      testing::RunRelume("session import --oni " + (dir / "rec.oni").string() + " --out " + (dir / "s").string() +
                         " --site " + RELUME_SOURCE_DIR + "/config/sites/athens-acropolis.yaml");
  EXPECT_NE(oni_without_start.exit_code, 0);
  EXPECT_NE(oni_without_start.output.find("--oni needs --start"), std::string::npos) << oni_without_start.output;

  const testing::CliResult ok = testing::RunRelume(base + " --intrinsics 20,20,8,6 --camera-id kinect");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("imported 3 RGB-D frame pairs of import:kinect"), std::string::npos) << ok.output;
  const testing::CliResult info = testing::RunRelume("session info " + (dir / "s").string());
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("import:kinect"), std::string::npos) << info.output;
  EXPECT_EQ(capture::SessionReader(dir / "s").Frames().size(), 6u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relume
