#include "capture/import.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>
#pragma GCC diagnostic pop
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "capture/session.h"
#include "core/error.h"
#include "core/sun/sun_position.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

struct Shot {
  std::string name;
  std::string local_time;  // EXIF "YYYY:MM:DD HH:MM:SS"
  int exposure_denominator = 250;
  std::string offset;  // OffsetTimeOriginal, "" = none
  std::string subsec;  // SubSecTimeOriginal, "" = none
  bool with_exposure = true;
};

Shot MakeShot(std::string name, std::string local_time, int exposure_denominator, std::string offset = "",
              std::string subsec = "", bool with_exposure = true) {
  return {std::move(name),   std::move(local_time), exposure_denominator,
          std::move(offset), std::move(subsec),     with_exposure};
}

// A small JPEG (or, with `extension` ".tif", a 16-bit TIFF) with the EXIF a camera writes;
// returns its bytes as written.
std::vector<std::uint8_t> WriteJpeg(const fs::path& path, const Shot& shot, const std::string& extension = ".jpg") {
  cv::Mat image(24, 32, extension == ".jpg" ? CV_8UC3 : CV_16UC3);
  cv::randu(image, 0, extension == ".jpg" ? 255 : 65535);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(extension, image, jpeg);
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  auto file = Exiv2::ImageFactory::open(jpeg.data(), static_cast<long>(jpeg.size()));
#pragma GCC diagnostic pop
  file->readMetadata();
  Exiv2::ExifData& exif = file->exifData();
  exif["Exif.Image.Make"] = "Canon";
  exif["Exif.Image.Model"] = "EOS 5D Mark IV";
  exif["Exif.Photo.DateTimeOriginal"] = shot.local_time;
  if (!shot.offset.empty()) exif["Exif.Photo.OffsetTimeOriginal"] = shot.offset;
  if (!shot.subsec.empty()) exif["Exif.Photo.SubSecTimeOriginal"] = shot.subsec;
  if (shot.with_exposure) exif["Exif.Photo.ExposureTime"] = Exiv2::URational(1, shot.exposure_denominator);
  exif["Exif.Photo.FNumber"] = Exiv2::URational(8, 1);
  exif["Exif.Photo.ISOSpeedRatings"] = static_cast<std::uint16_t>(100);
  file->writeMetadata();
  Exiv2::BasicIo& io = file->io();
  io.seek(0, Exiv2::BasicIo::beg);
  const Exiv2::DataBuf buffer = io.read(io.size());
  const std::vector<std::uint8_t> bytes(buffer.pData_, buffer.pData_ + buffer.size_);
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return bytes;
}

class ImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relume-import-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "card");
    options_.site = Site::FromDegrees(37.9715, 23.7267, 110.0);
    options_.inputs = {dir_ / "card"};
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  ImportOptions options_;
};

TEST_F(ImportTest, GroupsBracketsKeepsFilesAndPutsTheSunOnEveryFrame) {
  std::map<std::string, std::vector<std::uint8_t>> written;
  // Two brackets of three exposures five minutes apart, and a lone frame; written out of order.
  const std::vector<Shot> shots = {MakeShot("IMG_0004.JPG", "2026:06:21 09:05:00", 1000),
                                   MakeShot("IMG_0001.JPG", "2026:06:21 09:00:00", 1000),
                                   MakeShot("IMG_0002.JPG", "2026:06:21 09:00:01", 250, "", "50"),
                                   MakeShot("IMG_0003.JPG", "2026:06:21 09:00:02", 60),
                                   MakeShot("IMG_0005.JPG", "2026:06:21 09:05:01", 250),
                                   MakeShot("IMG_0006.JPG", "2026:06:21 09:05:02", 60),
                                   MakeShot("IMG_0007.JPG", "2026:06:21 09:05:03", 60)};
  for (const Shot& shot : shots) written[shot.name] = WriteJpeg(dir_ / "card" / shot.name, shot);
  options_.utc_offset = std::chrono::hours(3);
  const ImportSummary summary = ImportStills(options_, dir_ / "session");
  EXPECT_EQ(summary.frames, 7);
  EXPECT_EQ(summary.brackets, 3);  // the 7th repeats 1/60 s: a bracket of its own
  EXPECT_EQ(summary.device_id, "import:canon-eos-5d-mark-iv");

  const SessionReader reader(dir_ / "session");
  const std::vector<FrameRecord> frames = reader.Frames();
  ASSERT_EQ(frames.size(), 7u);
  std::map<std::int64_t, int> per_bracket;
  for (const FrameRecord& f : frames) ++per_bracket[*f.bracket_id];
  EXPECT_EQ(per_bracket.size(), 3u);
  for (const BracketRecord& b : reader.Brackets()) EXPECT_EQ(b.status, "complete");
  const UtcTime first = ParseIso8601("2026-06-21T06:00:00Z").utc;
  EXPECT_EQ(frames[0].utc, first);
  EXPECT_EQ(frames[1].utc, first + std::chrono::milliseconds(1500));  // SubSecTimeOriginal "50"
  EXPECT_DOUBLE_EQ(frames[0].exposure.exposure_time_s, 1.0 / 1000);
  EXPECT_DOUBLE_EQ(frames[2].exposure.exposure_time_s, 1.0 / 60);
  EXPECT_DOUBLE_EQ(frames[0].exposure.aperture_f, 8.0);
  EXPECT_DOUBLE_EQ(frames[0].exposure.iso, 100.0);
  for (const FrameRecord& f : frames) {
    const SunPosition sun = ComputeSunPosition(options_.site, f.utc);
    EXPECT_NEAR(f.sun_elevation_deg, RadToDeg(sun.elevation_rad), 1e-6);
    EXPECT_EQ(f.width, 32);
    EXPECT_EQ(f.file_format, "jpeg");
  }
  // Byte for byte: the stored file of the first frame is IMG_0001.JPG's.
  EXPECT_EQ(reader.ReadFrameFile(frames[0]), written["IMG_0001.JPG"]);
  EXPECT_EQ(reader.ReadFrameFile(frames[3]), written["IMG_0004.JPG"]);
}

// Linear 16-bit TIFFs (a raw converter's output) are stored as sensor-linear with --linear, so
// processing reads them without a camera response; without it they are camera-encoded.
TEST_F(ImportTest, LinearFilesAreStoredSensorLinear) {
  WriteJpeg(dir_ / "card" / "a.tif", MakeShot("a.tif", "2026:06:21 09:00:00", 250, "+03:00"), ".tif");
  WriteJpeg(dir_ / "card" / "b.tif", MakeShot("b.tif", "2026:06:21 09:00:01", 60, "+03:00"), ".tif");
  for (const bool linear : {false, true}) {
    options_.linear = linear;
    const fs::path out = dir_ / (linear ? "linear" : "encoded");
    ImportStills(options_, out);
    const std::vector<FrameRecord> frames = SessionReader(out).Frames();
    ASSERT_EQ(frames.size(), 2u);
    for (const FrameRecord& f : frames) {
      EXPECT_EQ(f.encoding, linear ? SampleEncoding::kSensorLinear : SampleEncoding::kCameraResponse);
      EXPECT_EQ(f.bits_per_sample, 16);
      EXPECT_EQ(f.file_format, "tiff");
    }
  }
}

TEST_F(ImportTest, TheFileTimeZoneWinsAndMissingValuesNameTheirFlag) {
  WriteJpeg(dir_ / "card" / "a.jpg", MakeShot("a.jpg", "2026:06:21 09:00:00", 250, "+02:00"));
  options_.utc_offset = std::chrono::hours(3);  // the file's own offset wins
  const ImportSummary summary = ImportStills(options_, dir_ / "zone");
  EXPECT_EQ(summary.first_utc, ParseIso8601("2026-06-21T07:00:00Z").utc);

  fs::create_directories(dir_ / "bare");
  WriteJpeg(dir_ / "bare" / "b.jpg", MakeShot("b.jpg", "2026:06:21 09:00:00", 250, "", "", /*with_exposure=*/false));
  ImportOptions bare = options_;
  bare.inputs = {dir_ / "bare"};
  bare.utc_offset.reset();
  const auto message = [&](const ImportOptions& o, const fs::path& out) -> std::string {
    try {
      ImportStills(o, out);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message(bare, dir_ / "s1").find("--tz"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "s1"));  // nothing is made when a file cannot be imported
  bare.utc_offset = std::chrono::hours(3);
  EXPECT_NE(message(bare, dir_ / "s2").find("--exposure-time"), std::string::npos);
  bare.exposure_time_s = 0.01;
  const ImportSummary filled = ImportStills(bare, dir_ / "s3");
  ASSERT_EQ(filled.notes.size(), 1u);
  EXPECT_NE(filled.notes[0].find("from --exposure-time"), std::string::npos);
  EXPECT_DOUBLE_EQ(SessionReader(dir_ / "s3").Frames().at(0).exposure.exposure_time_s, 0.01);

  std::ofstream(dir_ / "bare" / "c.jpg") << "not a jpeg";
  EXPECT_NE(message(bare, dir_ / "s4").find("c.jpg"), std::string::npos);
  EXPECT_THROW(ImportableFiles({dir_ / "nowhere"}), IoError);
}

}  // namespace
}  // namespace relume::capture
