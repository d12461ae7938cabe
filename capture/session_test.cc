#include "capture/session.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <string>
#include <utility>

#include "capture/durable_file.h"
#include "capture/session_check.h"
#include "core/error.h"
#include "core/raw_file.h"
#include "core/sun/sun_position.h"
#include "core/testing/dng_writer.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

class SessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("session_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
  }
  SessionInfo Info() const {
    SessionInfo info;
    info.name = "test";
    info.site = Site::FromDegrees(37.97153, 23.72644, 190);
    info.rig_config = "devices: []\n";
    info.software_version = "relume test";
    info.clock_name = "manual";
    info.created_utc = ParseIso8601("2026-06-21T06:00:00Z").utc;
    return info;
  }
  static drivers::StillFrame Frame16(int seed) {
    drivers::StillFrame frame;
    frame.device_id = "sim:dslr";
    frame.model = "SimDSLR";
    frame.image.pixels = cv::Mat(12, 16, CV_16UC3);
    cv::RNG rng(static_cast<std::uint64_t>(seed));
    rng.fill(frame.image.pixels, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(4096));
    frame.image.pixels.at<cv::Vec3w>(0, 0) = cv::Vec3w(static_cast<std::uint16_t>(seed), 1, 2);
    frame.image.layout = ColorLayout::kRgb;
    frame.image.encoding = SampleEncoding::kSensorLinear;
    frame.image.bits_per_sample = 12;
    frame.image.black_level = 64;
    frame.image.white_level = 4095;
    frame.exposure.exposure_time_s = 1.0 / 125;
    frame.exposure.aperture_f = 8;
    frame.exposure.iso = 100;
    frame.timing.host_utc = ParseIso8601("2026-06-21T09:00:00Z").utc + std::chrono::seconds(seed);
    frame.timing.host_monotonic = MonotonicTime(std::chrono::seconds(seed));
    frame.timing.device_timestamp = std::chrono::milliseconds(1000 + seed);
    frame.timing.sequence = static_cast<std::uint64_t>(seed);
    return frame;
  }
  fs::path dir_;
};

TEST_F(SessionTest, StillFramesRoundTripWithSunAndMetadata) {
  auto writer = SessionWriter::Create(dir_, Info());
  writer->AddDevice({"sim", "dslr", drivers::DeviceKind::kStillCamera, "SimDSLR", "42", "usb:1", {{"lens", "35mm"}}});
  const std::int64_t bracket = writer->BeginBracket("sim:dslr", Frame16(0).timing.host_utc, 2);
  const FrameRecord first = writer->WriteStillFrame(Frame16(1), bracket, 0);
  const FrameRecord second = writer->WriteStillFrame(Frame16(2), bracket, 1);
  writer->EndBracket(bracket, "complete", "");
  writer.reset();

  const SessionReader reader(dir_);
  EXPECT_EQ(reader.info().name, "test");
  EXPECT_NEAR(reader.info().site.latitude_deg(), 37.97153, 1e-12);
  ASSERT_EQ(reader.Devices().size(), 1u);
  EXPECT_EQ(reader.Devices()[0].details.at("lens"), "35mm");
  const std::vector<FrameRecord> frames = reader.Frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].id, first.id);
  EXPECT_EQ(frames[1].bracket_index, 1);
  EXPECT_EQ(frames[0].device_timestamp, std::chrono::milliseconds(1001));
  EXPECT_DOUBLE_EQ(frames[0].exposure.exposure_time_s, 1.0 / 125);
  EXPECT_TRUE(std::isnan(frames[0].exposure.gain_db));
  // The sun was computed for the frame's own UTC time at the session's site.
  const SunPosition sun = ComputeSunPosition(Info().site, Frame16(1).timing.host_utc);
  EXPECT_NEAR(frames[0].sun_elevation_deg, RadToDeg(sun.elevation_rad), 1e-6);
  EXPECT_NEAR(frames[0].sun_azimuth_deg, RadToDeg(sun.azimuth_rad), 1e-6);
  EXPECT_EQ(frames[0].sun_algorithm, kSunAlgorithmName);
  // Pixels decode exactly, with their encoding description.
  const CameraImage image = reader.LoadImage(frames[1]);
  EXPECT_EQ(cv::norm(image.pixels, Frame16(2).image.pixels, cv::NORM_INF), 0.0);
  EXPECT_EQ(image.black_level, 64);
  EXPECT_EQ(image.encoding, SampleEncoding::kSensorLinear);
  EXPECT_EQ(reader.Brackets()[0].status, "complete");
  EXPECT_TRUE(VerifySession(dir_).ok()) << VerifySession(dir_).Summary();
  EXPECT_NE(second.file_path, first.file_path);
}

TEST_F(SessionTest, CameraFilesAreKeptByteForByte) {
  auto writer = SessionWriter::Create(dir_, Info());
  drivers::StillFrame frame = Frame16(3);
  frame.original_file = {0x4e, 0x45, 0x46, 0x00, 0xff, 0x10, 0x20};  // opaque raw bytes
  frame.original_format = "nef";
  const FrameRecord record = writer->WriteStillFrame(frame);
  std::ifstream file(dir_ / record.file_path, std::ios::binary);
  const std::vector<std::uint8_t> stored((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  EXPECT_EQ(stored, frame.original_file);
  EXPECT_EQ(record.file_format, "nef");
  EXPECT_EQ(record.sha256, Sha256Hex(frame.original_file));
}

TEST_F(SessionTest, RawCameraFilesAreKeptAndDecodedThroughLibRaw) {
  relume::testing::DngImage dng;
  dng.mosaic = cv::Mat(24, 32, CV_16UC1);
  cv::RNG rng(7);
  rng.fill(dng.mosaic, cv::RNG::UNIFORM, cv::Scalar(512), cv::Scalar(16383));
  dng.black_level = 512;
  dng.white_level = 16383;
  drivers::StillFrame frame = Frame16(4);
  frame.original_file = relume::testing::EncodeDng(dng);
  frame.original_format = "dng";
  frame.image = DecodeRawFile(frame.original_file, "test.dng").image;  // what the driver delivers
  auto writer = SessionWriter::Create(dir_, Info());
  const FrameRecord record = writer->WriteStillFrame(frame);
  writer.reset();
  EXPECT_EQ(record.sha256, Sha256Hex(frame.original_file));
  EXPECT_EQ(record.layout, ColorLayout::kBayerRggb);
  EXPECT_EQ(record.width, 32);
  const CameraImage image = SessionReader(dir_).LoadImage(record);
  EXPECT_EQ(image.layout, ColorLayout::kBayerRggb);
  EXPECT_EQ(image.black_level, 512);
  EXPECT_EQ(image.white_level, 16383);
  EXPECT_EQ(cv::norm(image.pixels, dng.mosaic, cv::NORM_INF), 0.0);
}

TEST_F(SessionTest, ACameraFileRelumeCannotDecodeIsStillStored) {
  drivers::StillFrame frame = Frame16(5);
  frame.image = CameraImage{};  // the driver could not decode it
  frame.original_file = {0x46, 0x55, 0x4a, 0x49, 0x00, 0x01, 0x02};
  frame.original_format = "raf";
  frame.undecoded_reason = "X-Trans sensors are not supported";
  auto writer = SessionWriter::Create(dir_, Info());
  const FrameRecord record = writer->WriteStillFrame(frame);
  writer.reset();
  EXPECT_EQ(record.width, 0);
  EXPECT_EQ(record.encoding, SampleEncoding::kSensorLinear);
  EXPECT_DOUBLE_EQ(record.exposure.exposure_time_s, 1.0 / 125);
  EXPECT_TRUE(VerifySession(dir_).ok()) << VerifySession(dir_).Summary();
  const SessionReader reader(dir_);
  EXPECT_EQ(reader.ReadFrameFile(reader.Frames().at(0)), frame.original_file);
  try {
    reader.LoadImage(reader.Frames().at(0));
    ADD_FAILURE() << "undecodable raw file decoded";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("kept intact"), std::string::npos) << e.what();
  }
}

TEST_F(SessionTest, AFrameWithNeitherPixelsNorAFileIsRefused) {
  drivers::StillFrame frame = Frame16(6);
  frame.image = CameraImage{};
  auto writer = SessionWriter::Create(dir_, Info());
  EXPECT_THROW(writer->WriteStillFrame(frame), InvalidArgumentError);
}

TEST_F(SessionTest, RgbdDepthInMillimetres) {
  auto writer = SessionWriter::Create(dir_, Info());
  drivers::RgbdFrame frame;
  frame.device_id = "sim:kinect";
  frame.depth_m = cv::Mat(4, 5, CV_32FC1, cv::Scalar(1.2345f));
  frame.depth_m.at<float>(1, 1) = NAN;
  frame.depth_m.at<float>(2, 2) = 70.0f;  // beyond 16-bit millimetres: stored as "no measurement"
  frame.color.pixels = cv::Mat(4, 5, CV_8UC3, cv::Scalar(10, 20, 30));
  frame.depth_timing.host_utc = frame.color_timing.host_utc = ParseIso8601("2026-06-21T09:00:00Z").utc;
  const auto [depth, color] = writer->WriteRgbdFrame(frame);
  const SessionReader reader(dir_);
  const cv::Mat depth_m = reader.LoadDepth(depth);
  EXPECT_FLOAT_EQ(depth_m.at<float>(0, 0), 1.235f);  // rounded to 1 mm
  EXPECT_TRUE(std::isnan(depth_m.at<float>(1, 1)));
  EXPECT_TRUE(std::isnan(depth_m.at<float>(2, 2)));
  EXPECT_EQ(reader.LoadImage(color).pixels.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
}

TEST_F(SessionTest, WritingAFrameLeavesTheCallersPixelsAlone) {
  // The writer encodes RGB as the BGR OpenCV's codecs expect; that copy must not be the
  // caller's frame (the recorder meters the next exposure from it).
  const drivers::StillFrame still = Frame16(3);
  const cv::Mat still_before = still.image.pixels.clone();
  drivers::RgbdFrame rgbd;
  rgbd.device_id = "sim:kinect";
  rgbd.depth_m = cv::Mat(4, 5, CV_32FC1, cv::Scalar(1.5f));
  rgbd.color.pixels = cv::Mat(4, 5, CV_8UC3, cv::Scalar(1, 2, 3));
  const cv::Mat color_before = rgbd.color.pixels.clone();
  SessionWriterOptions png;
  png.rgbd_format = RgbdFileFormat::kPng;
  auto writer = SessionWriter::Create(dir_, Info(), png);
  writer->WriteStillFrame(still);
  writer->WriteRgbdFrame(rgbd);
  EXPECT_EQ(cv::norm(still.image.pixels, still_before, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(rgbd.color.pixels, color_before, cv::NORM_INF), 0.0);
}

TEST_F(SessionTest, RgbdFramesAreZstdTiffByDefaultAndPngOnRequest) {
  drivers::RgbdFrame frame;
  frame.device_id = "sim:kinect";
  frame.depth_m = cv::Mat(6, 7, CV_32FC1, cv::Scalar(2.5f));
  frame.depth_m.at<float>(3, 4) = NAN;
  frame.depth_m.at<float>(1, 2) = 1.23456789f;  // not a whole millimetre
  frame.depth_m.at<float>(2, 2) = -1.0f;        // not a distance: stored as "none"
  frame.color.pixels = cv::Mat(6, 7, CV_8UC3, cv::Scalar(40, 50, 60));
  frame.depth_timing.host_utc = frame.color_timing.host_utc = ParseIso8601("2026-06-21T09:00:00Z").utc;
  struct Case {
    RgbdFileFormat format;
    DepthUnits units;
    std::string depth_file, color_file;
  };
  for (const Case& c : {Case{RgbdFileFormat::kTiffZstd, DepthUnits::kMillimetres, "tiff", "tiff"},
                        Case{RgbdFileFormat::kPng, DepthUnits::kMillimetres, "png", "png"},
                        Case{RgbdFileFormat::kTiffZstd, DepthUnits::kMetres, "tiff", "tiff"},
                        Case{RgbdFileFormat::kPng, DepthUnits::kMetres, "exr", "png"}}) {
    const bool metres = c.units == DepthUnits::kMetres;
    const std::string name = c.depth_file + (metres ? "-metres" : "-mm");
    const fs::path dir = dir_ / name;
    SessionWriterOptions options;
    options.rgbd_format = c.format;
    options.depth_units = c.units;
    auto writer = SessionWriter::Create(dir, Info(), options);
    const auto [depth, color] = writer->WriteRgbdFrame(frame);
    writer.reset();
    EXPECT_EQ(depth.file_format, c.depth_file) << name;
    EXPECT_EQ(color.file_format, c.color_file) << name;
    EXPECT_EQ(depth.bits_per_sample, metres ? 32 : 16) << name;
    const SessionReader reader(dir);
    const FrameRecord stored = reader.Frames().front();
    EXPECT_EQ(stored.file_format, c.depth_file);
    EXPECT_EQ(stored.bits_per_sample, metres ? 32 : 16);
    const cv::Mat depth_m = reader.LoadDepth(stored);
    ASSERT_EQ(depth_m.type(), CV_32FC1) << name;
    EXPECT_FLOAT_EQ(depth_m.at<float>(0, 0), 2.5f) << name;
    EXPECT_TRUE(std::isnan(depth_m.at<float>(3, 4))) << name;
    EXPECT_TRUE(std::isnan(depth_m.at<float>(2, 2))) << name;
    if (metres) {
      EXPECT_EQ(depth_m.at<float>(1, 2), 1.23456789f) << name << ": metres keep the float exactly";
    } else {
      EXPECT_FLOAT_EQ(depth_m.at<float>(1, 2), 1.235f) << name << ": millimetres round";
    }
    EXPECT_EQ(reader.LoadImage(color).pixels.at<cv::Vec3b>(5, 6), cv::Vec3b(40, 50, 60)) << name;
    EXPECT_TRUE(VerifySession(dir).ok()) << VerifySession(dir).Summary();
  }
  EXPECT_EQ(ParseRgbdFileFormat("tiff"), RgbdFileFormat::kTiffZstd);
  EXPECT_EQ(ParseRgbdFileFormat("png"), RgbdFileFormat::kPng);
  EXPECT_THROW(ParseRgbdFileFormat("jpeg"), InvalidArgumentError);
  EXPECT_EQ(ParseDepthUnits("metres"), DepthUnits::kMetres);
  EXPECT_EQ(ParseDepthUnits("millimetres"), DepthUnits::kMillimetres);
  EXPECT_THROW(ParseDepthUnits("inches"), InvalidArgumentError);
}

TEST_F(SessionTest, VerifyFindsTamperingAndMissingFiles) {
  auto writer = SessionWriter::Create(dir_, Info());
  const FrameRecord a = writer->WriteStillFrame(Frame16(1));
  const FrameRecord b = writer->WriteStillFrame(Frame16(2));
  writer.reset();
  {
    std::fstream file(dir_ / a.file_path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(100);
    file.put('\x5a');
  }
  fs::remove(dir_ / b.file_path);
  const VerifyReport report = VerifySession(dir_);
  EXPECT_FALSE(report.ok());
  EXPECT_EQ(report.checksum_mismatches, 1);
  EXPECT_EQ(report.missing_files, 1);
  const SessionReader reader(dir_);
  EXPECT_THROW(reader.LoadImage(reader.Frames()[0]), IoError);
}

TEST_F(SessionTest, RecoverCleansDebrisAndKeepsUnacknowledgedFiles) {
  auto writer = SessionWriter::Create(dir_, Info());
  writer->BeginBracket("sim:dslr", Frame16(0).timing.host_utc, 3);
  const FrameRecord kept = writer->WriteStillFrame(Frame16(1));
  writer.reset();
  // What a crash can leave: a half-written temp file and a complete file whose row never
  // committed.
  std::ofstream(dir_ / "frames" / "sim_dslr" / "00000009_still.tiff.tmp") << "half";
  std::ofstream(dir_ / "frames" / "sim_dslr" / "00000010_still.tiff") << "complete but unacknowledged";
  VerifyReport before = VerifySession(dir_);
  EXPECT_EQ(before.temp_files, 1);
  EXPECT_EQ(before.orphan_files, 1);
  EXPECT_EQ(before.open_brackets, 1);
  const RecoverReport report = RecoverSession(dir_);
  EXPECT_EQ(report.temp_files_removed, 1);
  EXPECT_EQ(report.orphans_kept, 1);
  EXPECT_EQ(report.brackets_closed, 1);
  EXPECT_TRUE(fs::exists(dir_ / "orphans" / "sim_dslr" / "00000010_still.tiff"));
  const VerifyReport after = VerifySession(dir_);
  EXPECT_TRUE(after.ok()) << after.Summary();
  const SessionReader reader(dir_);
  EXPECT_EQ(reader.Brackets()[0].status, "partial");
  ASSERT_EQ(reader.Events().size(), 1u);
  EXPECT_EQ(reader.Events()[0].type, "recover");
  EXPECT_EQ(reader.Frames()[0].sha256, kept.sha256);
  // Appending after recovery continues without reusing names.
  auto append = SessionWriter::Append(dir_);
  EXPECT_NE(append->WriteStillFrame(Frame16(5)).file_path, kept.file_path);
  EXPECT_TRUE(VerifySession(dir_).ok());
}

TEST_F(SessionTest, AFullDiskStopsWritingAndKeepsAcknowledgedFrames) {
  auto writer = SessionWriter::Create(dir_, Info());
  const FrameRecord acknowledged = writer->WriteStillFrame(Frame16(1));
  // Simulate a full disk with a file-size limit (EFBIG, the same path as ENOSPC).
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit old_limit{};
  getrlimit(RLIMIT_FSIZE, &old_limit);
  rlimit small = old_limit;
  small.rlim_cur = 64;
  setrlimit(RLIMIT_FSIZE, &small);
  try {
    writer->WriteStillFrame(Frame16(2));
    setrlimit(RLIMIT_FSIZE, &old_limit);
    FAIL() << "expected an IoError";
  } catch (const IoError& e) {
    setrlimit(RLIMIT_FSIZE, &old_limit);
    EXPECT_NE(std::string(e.what()).find("disk is full"), std::string::npos) << e.what();
  }
  writer.reset();
  const VerifyReport report = VerifySession(dir_);
  EXPECT_TRUE(report.ok()) << report.Summary();
  EXPECT_EQ(report.frames_checked, 1);
  EXPECT_EQ(SessionReader(dir_).Frames()[0].sha256, acknowledged.sha256);
}

TEST_F(SessionTest, RefusesExistingSessionsAndNewerSchemas) {
  SessionWriter::Create(dir_, Info()).reset();
  EXPECT_THROW(SessionWriter::Create(dir_, Info()), IoError);
  EXPECT_THROW(SessionReader(dir_ / "nowhere"), IoError);
  {
    Database db((dir_ / kSessionDatabaseName).string(), Database::Mode::kReadWrite);
    db.Exec("UPDATE meta SET value = '99' WHERE key = 'schema_version'");
  }
  try {
    SessionReader reader(dir_);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("newer relume"), std::string::npos);
  }
}

TEST_F(SessionTest, DescribeSummarises) {
  auto writer = SessionWriter::Create(dir_, Info());
  writer->AddDevice({"sim", "dslr", drivers::DeviceKind::kStillCamera, "SimDSLR", "", "", {}});
  writer->WriteStillFrame(Frame16(1));
  writer->AddEvent({0, Frame16(1).timing.host_utc, {}, "sim:dslr", "fault", "busy"});
  writer.reset();
  const std::string text = DescribeSession(dir_);
  EXPECT_NE(text.find("sim:dslr still: 1"), std::string::npos) << text;
  EXPECT_NE(text.find("1 fault"), std::string::npos) << text;
}

}  // namespace
}  // namespace relume::capture
