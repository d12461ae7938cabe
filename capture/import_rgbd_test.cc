#include "capture/import_rgbd.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "capture/durable_file.h"
#include "capture/playback.h"
#include "capture/recorder.h"
#include "capture/rgbd_geometry.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/sun/sun_position.h"
#include "drivers/device_error.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> Encode(const cv::Mat& image, const std::string& extension) {
  std::vector<std::uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(extension, image, bytes));
  return bytes;
}

void WriteFile(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// 1773999000 s and `microseconds` as a TUM timestamp.
std::string Stamp(int microseconds) {
  char text[32];
  std::snprintf(text, sizeof(text), "1773999000.%06d", microseconds);
  return text;
}

// A recording in the TUM RGB-D layout: colour frames 1/30 s apart from t0, each depth frame
// 2 ms before its colour frame; an extra colour frame at the end without depth.
class ImportRgbdTest : public ::testing::Test {
 protected:
  static constexpr int kFrames = 5;
  static constexpr int kWidth = 32, kHeight = 24;

  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relume-import-rgbd-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    options_.folder = dir_ / "rec";
    options_.site = Site::FromDegrees(47.37689, 8.54169, 460.0);
    options_.color_intrinsics.fx = options_.color_intrinsics.fy = 30.0;
    options_.color_intrinsics.cx = 16.0;
    options_.color_intrinsics.cy = 12.0;
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes the recording with depth values of `units` per metre (1.0-1.5 m and a hole).
  void WriteRecording(double units, const std::string& color_extension = ".png") {
    fs::create_directories(options_.folder);
    std::ofstream rgb_list(options_.folder / "rgb.txt"), depth_list(options_.folder / "depth.txt");
    rgb_list << "# color images\n# timestamp filename\n";
    depth_list << "# depth maps\n";
    cv::RNG rng(7);
    for (int k = 0; k <= kFrames; ++k) {
      const std::string stamp = Stamp(100000 + k * 33333);
      cv::Mat color(kHeight, kWidth, CV_8UC3);
      rng.fill(color, cv::RNG::UNIFORM, 0, 255);
      const std::string color_name = "rgb/" + std::to_string(k) + color_extension;
      colors_[color_name] = Encode(color, color_extension);
      WriteFile(options_.folder / color_name, colors_[color_name]);
      rgb_list << stamp << " " << color_name << "\n";
      if (k == kFrames) break;  // the last colour frame has no depth
      cv::Mat depth(kHeight, kWidth, CV_16UC1);
      for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x)
          depth.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(std::lround(units * (1.0 + 0.02 * x + 0.001 * k)));
      depth.at<std::uint16_t>(3, 4) = 0;  // a hole
      const std::string depth_name = "depth/" + std::to_string(k) + ".png";
      depths_[depth_name] = Encode(depth, ".png");
      depth_values_.push_back(depth);
      WriteFile(options_.folder / depth_name, depths_[depth_name]);
      // 2 ms before the colour frame.
      depth_list << Stamp(100000 + k * 33333 - 2000) << " " << depth_name << "\n";
    }
  }

  fs::path dir_;
  RgbdImportOptions options_;
  std::map<std::string, std::vector<std::uint8_t>> colors_, depths_;
  std::vector<cv::Mat> depth_values_;
};

TEST_F(ImportRgbdTest, PairsFramesKeepsTheFilesAndRecordsTheGeometry) {
  WriteRecording(1000.0);
  const RgbdImportSummary summary = ImportRgbd(options_, dir_ / "session");
  EXPECT_EQ(summary.pairs, kFrames);
  EXPECT_EQ(summary.unpaired_color, 1);
  EXPECT_EQ(summary.unpaired_depth, 0);
  EXPECT_NEAR(summary.largest_pair_gap_s, 0.002, 1e-9);
  EXPECT_FALSE(summary.depth_converted);
  EXPECT_EQ(summary.device_id, "import:rgbd");

  const SessionReader reader(dir_ / "session");
  const std::vector<FrameRecord> frames = reader.Frames();
  ASSERT_EQ(frames.size(), 2u * kFrames);
  const UtcTime t0 = UtcTime(std::chrono::seconds(1773999000)) + std::chrono::microseconds(100000);
  for (int k = 0; k < kFrames; ++k) {
    const FrameRecord& depth = frames[static_cast<std::size_t>(2 * k)];
    const FrameRecord& color = frames[static_cast<std::size_t>(2 * k + 1)];
    EXPECT_EQ(depth.stream, "depth");
    EXPECT_EQ(color.stream, "color");
    // Times exact to the microsecond the lists give.
    EXPECT_EQ(color.utc, t0 + std::chrono::microseconds(k * 33333));
    EXPECT_EQ(depth.utc, color.utc - std::chrono::milliseconds(2));
    // Byte for byte, both files.
    EXPECT_EQ(reader.ReadFrameFile(color), colors_["rgb/" + std::to_string(k) + ".png"]);
    EXPECT_EQ(reader.ReadFrameFile(depth), depths_["depth/" + std::to_string(k) + ".png"]);
    EXPECT_EQ(color.sha256, Sha256Hex(colors_["rgb/" + std::to_string(k) + ".png"]));
    // Depth in metres, the hole NaN.
    const cv::Mat metres = reader.LoadDepth(depth);
    EXPECT_TRUE(std::isnan(metres.at<float>(3, 4)));
    EXPECT_NEAR(metres.at<float>(5, 10), depth_values_[static_cast<std::size_t>(k)].at<std::uint16_t>(5, 10) * 1e-3,
                1e-6);
    // The sun for the site, and the pixels as decoded.
    const SunPosition sun = ComputeSunPosition(options_.site, color.utc);
    EXPECT_NEAR(color.sun_elevation_deg, RadToDeg(sun.elevation_rad), 1e-6);
    const CameraImage image = reader.LoadImage(color);
    EXPECT_EQ(image.pixels.cols, kWidth);
    EXPECT_EQ(image.bits_per_sample, 8);
  }
  // The geometry row: registered, the intrinsics given, the first colour frame's size.
  const std::vector<CalibrationRecord> rows = reader.Calibrations();
  const CalibrationRecord* geometry = RgbdGeometryAt(rows, "import:rgbd", frames[0].id);
  ASSERT_NE(geometry, nullptr);
  drivers::RgbdFrame g;
  ApplyRgbdGeometryJson(geometry->json, &g);
  EXPECT_TRUE(g.registered_to_color);
  EXPECT_EQ(g.color_intrinsics.width, kWidth);
  EXPECT_EQ(g.color_intrinsics.height, kHeight);
  EXPECT_DOUBLE_EQ(g.color_intrinsics.fx, 30.0);
  EXPECT_DOUBLE_EQ(g.color_intrinsics.cy, 12.0);
}

// Plays `recorded` back into a new session `out` stored with `options`: every recorded RGB-D
// pair, on a clock that does not pace. Returns its frames.
std::vector<FrameRecord> Replay(const fs::path& recorded, const fs::path& out, const SessionWriterOptions& options) {
  ManualClock clock(UtcTime(std::chrono::seconds(1773999000)));
  PlaybackBackend playback(recorded);
  SessionInfo info;
  info.name = "replay";
  info.clock_name = clock.name();
  info.created_utc = clock.NowUtc();
  auto writer = SessionWriter::Create(out, info, options);
  RecorderOptions recorder_options;
  recorder_options.schedule.kind = ScheduleOptions::Kind::kCount;
  recorder_options.schedule.count = 1;
  Recorder recorder(*writer, clock, recorder_options);
  const std::vector<drivers::DeviceInfo> devices = playback.Enumerate();
  EXPECT_EQ(devices.size(), 1u);
  auto sensor = playback.OpenRgbdSensor(devices.front());
  const drivers::RgbdStreamConfig config = sensor->SupportedConfigs().front();
  recorder.AddRgbdSensor(std::move(sensor), nullptr, config, 5);
  std::atomic<bool> stop{false};
  recorder.Run(stop);
  writer.reset();
  return SessionReader(out).Frames();
}

// Frames played back from a session are stored again byte for byte, as still frames are: the
// colour file always (here the recording's JPEGs, which relume would otherwise store as PNG or
// TIFF), the depth file when the new session stores depth in its format and units; otherwise
// the depth is encoded again, to the same metres.
TEST_F(ImportRgbdTest, APlayedBackRecordingKeepsItsFilesByteForByte) {
  WriteRecording(1000.0, ".jpg");
  ImportRgbd(options_, dir_ / "session");
  const SessionReader recorded(dir_ / "session");
  const std::vector<FrameRecord> originals = recorded.Frames();
  ASSERT_EQ(originals.size(), 2u * kFrames);

  SessionWriterOptions as_recorded;  // what a playback rig stores by default: 16-bit PNG millimetres
  as_recorded.rgbd_format = RgbdFileFormat::kPng;
  as_recorded.depth_units = DepthUnits::kMillimetres;
  const std::vector<FrameRecord> same = Replay(dir_ / "session", dir_ / "replay-png", as_recorded);
  ASSERT_EQ(same.size(), originals.size());
  for (std::size_t i = 0; i < same.size(); ++i) {
    EXPECT_EQ(same[i].stream, originals[i].stream);
    EXPECT_EQ(same[i].file_format, originals[i].file_format) << i;
    EXPECT_EQ(same[i].sha256, originals[i].sha256) << i << " " << same[i].stream;
  }
  EXPECT_EQ(same[1].file_format, "jpeg");

  SessionWriterOptions tiff_metres;  // a rig that sets rgbd_format: tiff and rgbd_depth: metres
  tiff_metres.rgbd_format = RgbdFileFormat::kTiffZstd;
  tiff_metres.depth_units = DepthUnits::kMetres;
  const std::vector<FrameRecord> converted = Replay(dir_ / "session", dir_ / "replay-tiff", tiff_metres);
  ASSERT_EQ(converted.size(), originals.size());
  const SessionReader replayed(dir_ / "replay-tiff");
  for (std::size_t i = 0; i < converted.size(); i += 2) {
    EXPECT_EQ(converted[i].file_format, "tiff");
    EXPECT_NE(converted[i].sha256, originals[i].sha256);
    const cv::Mat a = recorded.LoadDepth(originals[i]), b = replayed.LoadDepth(converted[i]);
    ASSERT_EQ(a.size(), b.size());
    int holes = 0, differ = 0;
    for (int y = 0; y < a.rows; ++y) {
      for (int x = 0; x < a.cols; ++x) {
        const float u = a.at<float>(y, x), v = b.at<float>(y, x);
        holes += std::isnan(u) ? 1 : 0;
        differ += std::isnan(u) != std::isnan(v) || (!std::isnan(u) && u != v) ? 1 : 0;
      }
    }
    EXPECT_EQ(holes, 1) << "depth frame " << i / 2;  // the recording's hole, NaN in both
    EXPECT_EQ(differ, 0) << "depth frame " << i / 2;
    EXPECT_EQ(converted[i + 1].sha256, originals[i + 1].sha256);  // the JPEG colour, as recorded
    EXPECT_EQ(converted[i + 1].file_format, "jpeg");
  }
}

// The benchmark's own depth scale (5000 per metre): depth is stored as float metres, exactly,
// and the events keep each original's SHA-256.
TEST_F(ImportRgbdTest, OtherDepthUnitsAreStoredAsMetres) {
  WriteRecording(5000.0, ".jpg");
  options_.depth_units_per_metre = 5000.0;
  const RgbdImportSummary summary = ImportRgbd(options_, dir_ / "session");
  EXPECT_TRUE(summary.depth_converted);
  ASSERT_EQ(summary.original_depth_sha256.size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(summary.original_depth_sha256[0], "depth/0.png " + Sha256Hex(depths_["depth/0.png"]));
  const SessionReader reader(dir_ / "session");
  const std::vector<FrameRecord> frames = reader.Frames();
  ASSERT_EQ(frames.size(), 2u * kFrames);
  EXPECT_EQ(frames[0].file_format, "exr");
  EXPECT_EQ(frames[1].file_format, "jpeg");
  EXPECT_EQ(reader.ReadFrameFile(frames[1]), colors_["rgb/0.jpg"]);
  const cv::Mat metres = reader.LoadDepth(frames[0]);
  EXPECT_FLOAT_EQ(metres.at<float>(5, 10), static_cast<float>(depth_values_[0].at<std::uint16_t>(5, 10) / 5000.0));
  EXPECT_TRUE(std::isnan(metres.at<float>(3, 4)));
  int provenance = 0;
  for (const EventRecord& e : reader.Events()) {
    provenance += e.message.find(Sha256Hex(depths_["depth/0.png"])) != std::string::npos;
  }
  EXPECT_EQ(provenance, 1);
}

TEST_F(ImportRgbdTest, DepthNotRegisteredToColourIsRefusedAndNothingIsMade) {
  WriteRecording(1000.0);
  WriteFile(options_.folder / "depth/3.png", Encode(cv::Mat(12, 16, CV_16UC1, cv::Scalar(1000)), ".png"));
  try {
    ImportRgbd(options_, dir_ / "session");
    FAIL() << "a depth frame of another size was imported";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("depth/3.png is 16x12"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("registered to colour"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_ / "session"));
}

// Each file is read and decoded once, as it is stored: a frame refused after others were
// stored removes what the import made (the recording's files stay where they are), so the same
// --out works again, and a folder the user made before is left as it was.
TEST_F(ImportRgbdTest, AFrameRefusedAfterOthersWereStoredRemovesWhatTheImportMade) {
  WriteRecording(1000.0);
  WriteFile(options_.folder / "depth/4.png", {'n', 'o', 't', ' ', 'a', ' ', 'p', 'n', 'g'});  // the last pair
  options_.frames_per_batch = 1;  // frames 0-3 are stored (and committed) before it
  try {
    ImportRgbd(options_, dir_ / "session");
    FAIL() << "an undecodable depth frame was imported";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("depth/4.png: not a 16-bit"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_ / "session"));

  const fs::path mine = dir_ / "mine";
  fs::create_directories(mine);
  WriteFile(mine / "notes.txt", {'k', 'e', 'e', 'p'});
  EXPECT_THROW(ImportRgbd(options_, mine), InvalidArgumentError);
  std::vector<fs::path> left;
  for (const fs::directory_entry& entry : fs::directory_iterator(mine)) left.push_back(entry.path().filename());
  EXPECT_EQ(left, std::vector<fs::path>{"notes.txt"});

  WriteRecording(1000.0);  // the file restored: both folders take the import
  EXPECT_EQ(ImportRgbd(options_, dir_ / "session").pairs, kFrames);
  EXPECT_EQ(ImportRgbd(options_, mine).pairs, kFrames);
  EXPECT_TRUE(fs::exists(mine / "notes.txt"));
  EXPECT_EQ(SessionReader(dir_ / "session").Frames().size(), 2u * kFrames);

  // A folder that holds a session already is refused, and that session is left whole.
  EXPECT_THROW(ImportRgbd(options_, dir_ / "session"), IoError);
  EXPECT_EQ(SessionReader(dir_ / "session").Frames().size(), 2u * kFrames);
}

TEST_F(ImportRgbdTest, BadListsFilesAndOptionsAreNamed) {
  WriteRecording(1000.0);
  { std::ofstream(options_.folder / "depth.txt", std::ios::app) << "1773999001.5\n"; }
  try {
    ImportRgbd(options_, dir_ / "session");
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("depth.txt line 7"), std::string::npos) << e.what();
  }
  WriteRecording(1000.0);
  fs::remove(options_.folder / "rgb/2.png");
  EXPECT_THROW(ImportRgbd(options_, dir_ / "session"), IoError);
  EXPECT_FALSE(fs::exists(dir_ / "session"));

  WriteRecording(1000.0);
  options_.max_pair_gap_s = 0.001;  // the streams are 2 ms apart
  try {
    ImportRgbd(options_, dir_ / "session");
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("--max-pair-gap"), std::string::npos) << e.what();
  }

  RgbdImportOptions bad = options_;
  bad.color_intrinsics.fx = 0.0;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("--intrinsics"), std::string::npos);
  bad = options_;
  bad.depth_units_per_metre = -1.0;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("--depth-scale"), std::string::npos);
  bad = options_;
  bad.color_intrinsics.width = 64;  // not the frames' size
  bad.color_intrinsics.height = 48;
  bad.max_pair_gap_s = 0.02;
  EXPECT_THROW(ImportRgbd(bad, dir_ / "session"), InvalidArgumentError);
}

// A recording played back as a sensor (the interface an OpenNI2 .oni player implements; the
// real one is tested in drivers/openni2/openni2_backend_test.cc): `frames` frames 33.3 ms apart
// on a device clock that starts at 5 s, then the end (kTimeout).
class PlayedRecording : public drivers::RgbdSensor {
 public:
  explicit PlayedRecording(int frames) : frames_(frames) {
    info_.backend = "played";
    info_.id = "rec.oni";
  }
  const drivers::DeviceInfo& info() const override { return info_; }
  std::vector<drivers::RgbdStreamConfig> SupportedConfigs() const override { return {drivers::RgbdStreamConfig{}}; }
  void Start(const drivers::RgbdStreamConfig&) override { streaming_ = true; }
  void Stop() override { streaming_ = false; }
  bool streaming() const override { return streaming_; }
  drivers::RgbdFrame WaitForFrame(Nanoseconds) override {
    if (next_ == frames_) throw drivers::DeviceError(drivers::DeviceErrorKind::kTimeout, "played:rec.oni", "the end");
    drivers::RgbdFrame f;
    f.depth_m = cv::Mat(12, 16, CV_32FC1, cv::Scalar(1.25f + 0.001f * static_cast<float>(next_)));
    f.color.pixels = cv::Mat(12, 16, CV_8UC3, cv::Scalar(10, 20, 30 + next_));
    f.color.layout = ColorLayout::kRgb;
    f.color.bits_per_sample = 8;
    f.color.white_level = 255;
    f.depth_intrinsics = f.color_intrinsics = PinholeIntrinsics::FromHorizontalFov(16, 12, 1.0);
    f.registered_to_color = true;
    const Nanoseconds device = std::chrono::seconds(5) + std::chrono::microseconds(33333) * next_;
    f.depth_timing.device_timestamp = device;
    f.color_timing.device_timestamp = device + std::chrono::milliseconds(1);
    f.depth_timing.host_utc = f.color_timing.host_utc = UtcNow();  // the playback's clock: not the recording's
    ++next_;
    return f;
  }

 private:
  drivers::DeviceInfo info_;
  int frames_, next_ = 0;
  bool streaming_ = false;
};

TEST_F(ImportRgbdTest, APlayedRecordingIsPlacedAtItsStatedStart) {
  PlayedRecording recording(7);
  recording.Start({});
  RgbdStreamImportOptions options;
  options.site = options_.site;
  options.start_utc = ParseIso8601("2026-03-20T11:00:00Z").utc;
  options.frames = 9;  // the recording claims 9: it ends after 7, which are kept and noted
  options.frames_per_batch = 3;
  options.source = "rec.oni";
  options.source_sha256 = "abc123";
  options.frame_timeout = std::chrono::milliseconds(10);
  const RgbdImportSummary summary = ImportRgbdStream(recording, options, dir_ / "session");
  EXPECT_EQ(summary.pairs, 7);
  EXPECT_EQ(summary.device_id, "import:rgbd");
  ASSERT_EQ(summary.notes.size(), 1u);
  EXPECT_EQ(summary.notes[0], "the recording ended after 7 of its 9 frames");
  EXPECT_NEAR(summary.largest_pair_gap_s, 0.001, 1e-9);
  const SessionReader reader(dir_ / "session");
  const std::vector<FrameRecord> frames = reader.Frames();
  ASSERT_EQ(frames.size(), 14u);
  for (int k = 0; k < 7; ++k) {
    const FrameRecord& depth = frames[static_cast<std::size_t>(2 * k)];
    EXPECT_EQ(depth.utc, *options.start_utc + std::chrono::microseconds(33333) * k);
    EXPECT_EQ(frames[static_cast<std::size_t>(2 * k + 1)].utc, depth.utc + std::chrono::milliseconds(1));
    EXPECT_NEAR(reader.LoadDepth(depth).at<float>(3, 3), 1.25 + 0.001 * k, 5e-4);  // millimetres
  }
  bool provenance = false;
  for (const EventRecord& e : reader.Events()) provenance = provenance || e.message.find("abc123") != std::string::npos;
  EXPECT_TRUE(provenance);

  // No start time: refused before anything is read or made.
  options.start_utc.reset();
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("--start"), std::string::npos);
  EXPECT_THROW(ImportRgbdStream(recording, options, dir_ / "other"), InvalidArgumentError);
  EXPECT_FALSE(fs::exists(dir_ / "other"));
  // A recording with no frame at all leaves nothing behind either.
  PlayedRecording empty(0);
  options.start_utc = ParseIso8601("2026-03-20T11:00:00Z").utc;
  EXPECT_THROW(ImportRgbdStream(empty, options, dir_ / "other"), drivers::DeviceError);
  EXPECT_FALSE(fs::exists(dir_ / "other"));
}

}  // namespace
}  // namespace relume::capture
