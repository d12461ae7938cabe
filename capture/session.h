// A capture session on disk: a folder with `session.sqlite` (SQLite, WAL, synchronous=FULL)
// and image files under `frames/`.
//
// Durability rule: a frame is *acknowledged* when SessionWriter::Write*Frame returns. By then
// its file was written to a temporary name, fsynced, renamed and its folder fsynced, and only
// then was its row (with the file's SHA-256) committed. A crash at any point leaves either an
// acknowledged frame that `verify` accepts, or debris that `recover` cleans up (a *.tmp file,
// or a complete file without a row, which is kept under orphans/, never deleted).
//
// Files: still frames keep the camera's own file byte for byte when it has one (raw, JPEG,
// TIFF); otherwise 8-bit PNG or 16-bit TIFF of the decoded pixels (RGB samples are stored in
// the file's native BGR order, as OpenCV writes them). RGB-D frames (SessionWriterOptions):
// depth as 16-bit millimetres, 0 = no measurement (range 0.001 .. 65.535 m), and colour, each
// as a zstd-compressed TIFF (capture/tiff_codec.h) or, on request, PNG.
//
// Every frame row carries the sun's azimuth/elevation at its UTC time for the session's site
// (core/sun, algorithm named in the row).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "capture/folder_lock.h"
#include "capture/sqlite.h"
#include "core/site.h"
#include "core/sun/sun_track.h"
#include "core/time.h"
#include "drivers/device_info.h"
#include "drivers/frame.h"

namespace relume::capture {

inline constexpr int kSessionSchemaVersion = 1;
inline constexpr const char* kSessionDatabaseName = "session.sqlite";

struct SessionInfo {
  std::string name;
  Site site;
  std::string rig_config;  // the rig's YAML, copied verbatim
  std::string software_version;
  std::string clock_name;  // which clock the frame times came from (core/clock.h)
  UtcTime created_utc;
};

struct FrameRecord {
  std::int64_t id = 0;
  std::string device_id;  // DeviceInfo::FullId()
  std::string stream;     // "still", "depth" or "color"
  std::optional<std::int64_t> bracket_id;
  int bracket_index = 0;
  UtcTime utc;
  MonotonicTime monotonic;
  std::optional<Nanoseconds> device_timestamp;
  std::uint64_t sequence = 0;
  drivers::ExposureRecord exposure;
  std::string file_path;  // relative to the session folder
  std::string sha256;
  std::string file_format;  // "png", "tiff", "jpeg", "nef", ...
  ColorLayout layout = ColorLayout::kRgb;
  SampleEncoding encoding = SampleEncoding::kCameraResponse;
  int bits_per_sample = 8;
  int black_level = 0;
  int white_level = 255;
  int width = 0;
  int height = 0;
  double sun_azimuth_deg = 0.0;
  double sun_elevation_deg = 0.0;
  std::string sun_algorithm;
  std::optional<double> sensor_temperature_c;
};

struct BracketRecord {
  std::int64_t id = 0;
  std::string device_id;
  UtcTime started_utc;
  int planned_count = 0;
  std::string status;  // "open", "complete", "partial"
  std::string reason;
};

struct EventRecord {
  std::int64_t id = 0;
  UtcTime utc;
  MonotonicTime monotonic;
  std::string device_id;  // empty for session-wide events
  std::string type;       // "fault", "retry", "reconnect", "skip", "note", "stop", ...
  std::string message;
};

struct CalibrationRecord {
  std::int64_t id = 0;
  UtcTime created_utc;
  std::string kind;  // "response", "chart", "profile"
  std::string device_id;
  std::string json;
  std::vector<std::int64_t> source_frame_ids;
};

// How the writer stores the frames it encodes itself (RGB-D depth and colour).
enum class RgbdFileFormat {
  kTiffZstd,  // lossless (capture/tiff_codec.h), 8.8 ms to encode a 640x480 pair (the default)
  kPng,       // lossless, readable by older tools too; 25 ms to encode the same pair
};
// How the writer stores depth. Millimetres are what real sensors deliver (OpenNI2 gives 16-bit
// millimetres); metres keep a simulated or filtered depth exactly (32-bit float, NaN = none).
enum class DepthUnits {
  kMillimetres,  // 16-bit unsigned, 0 = no depth: a .tiff or .png
  kMetres,       // 32-bit float: a .tiff (zstd, floating-point predictor), or .exr beside PNG colour
};
// Storage faults for simulated rigs (the rig key `storage_faults:`), so that a soak meets slow
// and full disks as the field does. Real storage has none.
struct StorageFaultPlan {
  double slow_write_ms = 0.0;  // real time added before every frame file is written
  double full_after_mb = 0.0;  // the disk is full once the session holds this much (0: never)
  bool IsValid(std::string* why) const;
  bool Any() const { return slow_write_ms > 0.0 || full_after_mb > 0.0; }
};

struct SessionWriterOptions {
  RgbdFileFormat rgbd_format = RgbdFileFormat::kTiffZstd;
  DepthUnits depth_units = DepthUnits::kMillimetres;
  StorageFaultPlan storage_faults;
};
// "tiff" or "png" (the rig key `rgbd_format`); throws InvalidArgumentError otherwise.
RgbdFileFormat ParseRgbdFileFormat(const std::string& text);
// "millimetres" or "metres" (the rig key `rgbd_depth`); throws InvalidArgumentError otherwise.
DepthUnits ParseDepthUnits(const std::string& text);

// Writes one session. Not thread-safe: callers serialise (the recorder owns one writer thread).
// A writer holds the session's folder lock (capture/folder_lock.h) while it lives: a second
// process that opens a writer on the same session gets an IoError naming the first.
class SessionWriter {
 public:
  // Creates a new session in `dir` (created if missing; must not already hold a session: a
  // database left by a creation that never finished, with no session row and no frame, is
  // replaced).
  static std::unique_ptr<SessionWriter> Create(const std::filesystem::path& dir, const SessionInfo& info,
                                               const SessionWriterOptions& options = {});
  // Appends to an existing session (after `recover`).
  static std::unique_ptr<SessionWriter> Append(const std::filesystem::path& dir,
                                               const SessionWriterOptions& options = {});

  void AddDevice(const drivers::DeviceInfo& device);
  std::int64_t BeginBracket(const std::string& device_id, UtcTime started_utc, int planned_count);
  void EndBracket(std::int64_t bracket_id, const std::string& status, const std::string& reason);

  // Store durably, then return the committed row (the frame is then acknowledged). A frame
  // with the camera's own file (StillFrame::original_file) is stored byte for byte even when
  // it carries no decoded pixels (a raw file relume cannot decode): its row then has width and
  // height 0 and the pixel fields of the format's kind. Throws InvalidArgumentError for a frame
  // with neither valid pixels nor a file, IoError when the storage fails.
  FrameRecord WriteStillFrame(const drivers::StillFrame& frame, std::optional<std::int64_t> bracket_id = std::nullopt,
                              int bracket_index = 0);
  // Two rows: depth and colour, committed together; with them, when the device's stream
  // geometry (intrinsics, registration) is new or changed, a calibration row of kind
  // "rgbd_geometry" (capture/rgbd_geometry.h) naming the two frames.
  std::pair<FrameRecord, FrameRecord> WriteRgbdFrame(const drivers::RgbdFrame& frame);
  // Several RGB-D frames acknowledged together (group commit): their images are encoded in
  // parallel, each file written and fsynced, each folder fsynced once, and all rows committed
  // in one transaction. Same durability as one at a time, far fewer fsyncs per frame.
  // A frame's recorded files (RgbdFrame::depth_file, color_file: a played session, an imported
  // recording) are stored byte for byte in place of encoding its pixels, which must be what
  // they decode to (the pixels give the row's fields): the colour file always, the depth file
  // when its format and units are the ones this writer stores depth in (SessionWriterOptions);
  // otherwise the depth is encoded as usual.
  std::vector<std::pair<FrameRecord, FrameRecord>> WriteRgbdFrames(std::span<const drivers::RgbdFrame> frames);

  std::int64_t AddEvent(const EventRecord& event);
  std::int64_t AddCalibration(const CalibrationRecord& calibration);

  const std::filesystem::path& dir() const { return dir_; }
  const Site& site() const { return site_; }
  std::uint64_t bytes_written() const { return bytes_written_; }

 private:
  SessionWriter(std::filesystem::path dir, std::unique_ptr<Database> db, Site site, SessionWriterOptions options,
                FolderLock lock);
  FrameRecord StoreFile(FrameRecord record, std::span<const std::uint8_t> bytes, bool sync_folder = true);
  // Sleeps or throws the disk-full IoError as options_.storage_faults says (simulated rigs).
  void InjectStorageFaults(const std::filesystem::path& path, std::size_t size) const;
  void InsertFrame(FrameRecord& record);

  std::filesystem::path dir_;
  FolderLock lock_;  // held while the writer lives (capture/folder_lock.h); released after db_ closes
  std::unique_ptr<Database> db_;
  Site site_;
  SessionWriterOptions options_;
  SunTrack sun_;
  std::uint64_t bytes_written_ = 0;
  std::int64_t file_counter_ = 0;
  std::map<std::string, std::string> rgbd_geometry_;  // per device: the last geometry stored
};

// Decodes a stored still or colour frame file: PNG, TIFF and JPEG through OpenCV (RGB order,
// pixel fields from the row), camera raw files through LibRaw (core/raw_file.h: the mosaic with
// the file's own layout, black and white level). `name` names the file in messages. Throws
// IoError (or InvalidArgumentError for a raw layout relume does not handle), saying that the
// stored file itself is intact.
CameraImage DecodeFrameImage(std::span<const std::uint8_t> bytes, const FrameRecord& frame, const std::string& name);
// Decodes a stored depth frame file to metres (NaN where there was no measurement): 16-bit
// millimetres (0: none) or 32-bit float metres. `samples_per_metre`, when given, receives which
// (1000 or 1). IoError naming `name` when the file is neither.
cv::Mat DecodeDepthFrame(std::span<const std::uint8_t> bytes, const FrameRecord& frame, const std::string& name,
                         double* samples_per_metre = nullptr);

// Reads a session (what calibration, processing and the player use).
class SessionReader {
 public:
  // Throws IoError when the folder holds no session, ConfigError for a schema from a newer relume.
  explicit SessionReader(const std::filesystem::path& dir);

  const SessionInfo& info() const { return info_; }
  const std::filesystem::path& dir() const { return dir_; }
  std::vector<drivers::DeviceInfo> Devices() const;
  std::vector<FrameRecord> Frames() const;  // in id (acknowledgement) order
  std::vector<BracketRecord> Brackets() const;
  std::vector<EventRecord> Events() const;
  std::vector<CalibrationRecord> Calibrations() const;

  // The frame's file, byte for byte. Throws IoError when it is missing or its checksum does not
  // match (when verify_checksum).
  std::vector<std::uint8_t> ReadFrameFile(const FrameRecord& frame, bool verify_checksum = true) const;
  // Decodes a still or colour frame's pixels (DecodeFrameImage). Throws IoError when the file
  // is missing, its checksum does not match (when verify_checksum) or it cannot be decoded.
  CameraImage LoadImage(const FrameRecord& frame, bool verify_checksum = true) const;
  // Depth in metres, NaN where there was no measurement (DecodeDepthFrame).
  cv::Mat LoadDepth(const FrameRecord& frame, bool verify_checksum = true) const;

 private:
  std::filesystem::path dir_;
  std::unique_ptr<Database> db_;
  SessionInfo info_;
};

}  // namespace relume::capture
