#include "capture/session.h"

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "capture/durable_file.h"
#include "capture/folder_lock.h"
#include "capture/path_policy.h"
#include "capture/rgbd_geometry.h"
#include "capture/tiff_codec.h"
#include "core/error.h"
#include "core/raw_file.h"

namespace relume::capture {

namespace fs = std::filesystem;

namespace {

// Schema migrations: entry i upgrades version i to i + 1.
const std::vector<std::string>& Migrations() {
  static const std::vector<std::string> migrations = {
      R"sql(
CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE session(id INTEGER PRIMARY KEY CHECK (id = 1), name TEXT NOT NULL, latitude_deg REAL NOT NULL,
  longitude_deg REAL NOT NULL, height_m REAL NOT NULL, rig_config TEXT NOT NULL, software_version TEXT NOT NULL,
  clock TEXT NOT NULL, created_utc_ns INTEGER NOT NULL);
CREATE TABLE devices(full_id TEXT PRIMARY KEY, backend TEXT NOT NULL, kind TEXT NOT NULL, model TEXT, serial TEXT,
  address TEXT, details_json TEXT);
CREATE TABLE brackets(id INTEGER PRIMARY KEY, device_id TEXT NOT NULL, started_utc_ns INTEGER NOT NULL,
  planned_count INTEGER NOT NULL, status TEXT NOT NULL, reason TEXT NOT NULL DEFAULT '');
CREATE TABLE frames(id INTEGER PRIMARY KEY, device_id TEXT NOT NULL, stream TEXT NOT NULL, bracket_id INTEGER,
  bracket_index INTEGER NOT NULL, utc_ns INTEGER NOT NULL, monotonic_ns INTEGER NOT NULL, device_timestamp_ns INTEGER,
  sequence INTEGER NOT NULL, exposure_time_s REAL, ev_compensation REAL, aperture_f REAL, iso REAL, gain_db REAL,
  file_path TEXT NOT NULL UNIQUE, sha256 TEXT NOT NULL, file_format TEXT NOT NULL, layout TEXT NOT NULL,
  encoding TEXT NOT NULL, bits_per_sample INTEGER NOT NULL, black_level INTEGER NOT NULL, white_level INTEGER NOT NULL,
  width INTEGER NOT NULL, height INTEGER NOT NULL, sun_azimuth_deg REAL NOT NULL, sun_elevation_deg REAL NOT NULL,
  sun_algorithm TEXT NOT NULL, sensor_temperature_c REAL);
CREATE INDEX frames_by_device ON frames(device_id, utc_ns);
CREATE TABLE events(id INTEGER PRIMARY KEY, utc_ns INTEGER NOT NULL, monotonic_ns INTEGER NOT NULL, device_id TEXT,
  type TEXT NOT NULL, message TEXT NOT NULL);
CREATE TABLE calibrations(id INTEGER PRIMARY KEY, created_utc_ns INTEGER NOT NULL, kind TEXT NOT NULL,
  device_id TEXT, json TEXT NOT NULL, source_frame_ids TEXT NOT NULL);
)sql",
  };
  return migrations;
}

int SchemaVersion(Database& db) {
  Statement exists = db.Prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'meta'");
  exists.Step();
  if (exists.Int(0) == 0) return 0;
  Statement version = db.Prepare("SELECT value FROM meta WHERE key = 'schema_version'");
  if (!version.Step()) return 0;
  const std::string text = version.Text(0);
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 0) {
    throw IoError(db.path(), "schema_version '" + text +
                                 "' is not a version number: the session database is damaged (its frames are "
                                 "still on disk under frames/)");
  }
  return value;
}

// Brings the schema to kSessionSchemaVersion; refuses a newer one.
void Migrate(Database& db) {
  const int version = SchemaVersion(db);
  if (version > kSessionSchemaVersion) {
    throw ConfigError(db.path(), 0, "schema_version",
                      "written by a newer relume (schema " + std::to_string(version) + ", this build reads up to " +
                          std::to_string(kSessionSchemaVersion) + "): update relume");
  }
  for (int v = version; v < kSessionSchemaVersion; ++v) {
    Transaction transaction(db);
    db.Exec(Migrations()[static_cast<std::size_t>(v)]);
    db.Prepare("INSERT OR REPLACE INTO meta(key, value) VALUES('schema_version', ?)")
        .Bind(1, std::to_string(v + 1))
        .Run();
    transaction.Commit();
  }
}

std::unique_ptr<Database> OpenDatabase(const fs::path& dir, Database::Mode mode) {
  auto db = std::make_unique<Database>((dir / kSessionDatabaseName).string(), mode);
  if (mode == Database::Mode::kReadOnly) {
    // A reader never writes, not even a schema: a database of another relume, or a file that
    // is not a session at all, is reported as it is.
    const int version = SchemaVersion(*db);
    if (version == 0) {
      throw IoError(db->path(),
                    "is not a relume session database (it has no session tables: an empty or foreign "
                    "file); nothing was changed");
    }
    if (version > kSessionSchemaVersion) Migrate(*db);  // throws the "newer relume" error
    return db;
  }
  db->Exec("PRAGMA journal_mode = WAL");
  db->Exec("PRAGMA synchronous = FULL");  // fsync the WAL at every commit: a committed row is durable
  db->Exec("PRAGMA foreign_keys = ON");
  Migrate(*db);
  return db;
}

// True when the folder's database was left by a creation that never finished (the disk filled,
// the process was killed): no session row and no frame. Such a database recorded nothing.
bool IsUnfinishedCreation(const fs::path& dir) {
  Database db((dir / kSessionDatabaseName).string(), Database::Mode::kReadOnly);
  if (SchemaVersion(db) == 0) return true;
  Statement sessions = db.Prepare("SELECT count(*) FROM session");
  sessions.Step();
  Statement frames = db.Prepare("SELECT count(*) FROM frames");
  frames.Step();
  return sessions.Int(0) == 0 && frames.Int(0) == 0;
}

std::int64_t Ns(UtcTime t) {
  return t.time_since_epoch().count();
}
std::int64_t Ns(MonotonicTime t) {
  return t.time_since_epoch().count();
}

ColorLayout ParseLayout(const std::string& text) {
  for (ColorLayout layout : {ColorLayout::kMono, ColorLayout::kRgb, ColorLayout::kBayerRggb, ColorLayout::kBayerBggr,
                             ColorLayout::kBayerGrbg, ColorLayout::kBayerGbrg}) {
    if (text == ToString(layout)) return layout;
  }
  throw IoError(text, "unknown colour layout in the session database");
}

// A JSON column of a session row, as type T; IoError naming the column when the database holds
// something else (edited or damaged).
template <typename T>
T ParseColumn(const Database& db, const std::string& text, const std::string& column) {
  try {
    return nlohmann::json::parse(text).get<T>();
  } catch (const nlohmann::json::exception& e) {
    throw IoError(db.path(), column + " is not what relume wrote (" + e.what() + "): the database is damaged");
  }
}

// An image file's pixels through OpenCV; IoError naming the file when it cannot be decoded
// (OpenCV reports some damaged headers by returning nothing, others by throwing).
cv::Mat DecodeWithOpenCv(std::span<const std::uint8_t> bytes, const std::string& name) {
  cv::Mat pixels;
  if (!bytes.empty() && bytes.size() <= static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    try {
      pixels = cv::imdecode(cv::_InputArray(bytes.data(), static_cast<int>(bytes.size())), cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception& e) {
      throw IoError(name, std::string("cannot decode the image file: ") + e.what());
    }
  }
  if (pixels.empty()) throw IoError(name, "cannot decode the image file (empty, truncated or damaged)");
  return pixels;
}

SampleEncoding ParseEncoding(const std::string& text) {
  return text == ToString(SampleEncoding::kSensorLinear) ? SampleEncoding::kSensorLinear
                                                         : SampleEncoding::kCameraResponse;
}

std::string Slug(const std::string& id) {
  std::string slug;
  for (char c : id) slug.push_back(std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_');
  return slug;
}

std::vector<std::uint8_t> Encode(const cv::Mat& pixels_rgb_or_mono, const std::string& extension) {
  // A new Mat for the BGR copy: converting into a header that shares the caller's pixels would
  // swap the caller's (const) frame in place.
  cv::Mat native;
  if (pixels_rgb_or_mono.channels() == 3) {
    cv::cvtColor(pixels_rgb_or_mono, native, cv::COLOR_RGB2BGR);
  } else {
    native = pixels_rgb_or_mono;
  }
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(extension, native, bytes)) throw IoError(extension, "OpenCV could not encode the frame");
  return bytes;
}

}  // namespace

bool StorageFaultPlan::IsValid(std::string* why) const {
  if (!(slow_write_ms >= 0.0 && slow_write_ms <= 60000.0)) {
    *why = "slow_write_ms must be within 0 .. 60000";
    return false;
  }
  if (!(full_after_mb >= 0.0 && std::isfinite(full_after_mb))) {
    *why = "full_after_mb must be 0 (never) or a positive size in MiB";
    return false;
  }
  return true;
}

RgbdFileFormat ParseRgbdFileFormat(const std::string& text) {
  if (text == "tiff") return RgbdFileFormat::kTiffZstd;
  if (text == "png") return RgbdFileFormat::kPng;
  throw InvalidArgumentError("unknown RGB-D file format '" + text + "': expected tiff (zstd, the default) or png");
}

DepthUnits ParseDepthUnits(const std::string& text) {
  if (text == "millimetres" || text == "mm") return DepthUnits::kMillimetres;
  if (text == "metres" || text == "m") return DepthUnits::kMetres;
  throw InvalidArgumentError("unknown depth unit '" + text +
                             "': expected millimetres (16-bit, as sensors deliver it; the default) or metres (32-bit "
                             "float, exact)");
}

SessionWriter::SessionWriter(fs::path dir, std::unique_ptr<Database> db, Site site, SessionWriterOptions options,
                             FolderLock lock)
    : dir_(std::move(dir)), lock_(std::move(lock)), db_(std::move(db)), site_(site), options_(options), sun_(site) {
  Statement count = db_->Prepare("SELECT coalesce(max(id), 0) FROM frames");
  count.Step();
  file_counter_ = count.Int(0);
}

std::unique_ptr<SessionWriter> SessionWriter::Create(const fs::path& dir, const SessionInfo& info,
                                                     const SessionWriterOptions& options) {
  std::string why;
  if (!info.site.IsValid(&why)) throw InvalidArgumentError("session site: " + why);
  CreateDirectoryDurably(dir);
  FolderLock lock = FolderLock::Acquire(dir, "capture");
  if (fs::exists(dir / kSessionDatabaseName)) {
    if (!IsUnfinishedCreation(dir)) {
      throw IoError(dir.string(), "already holds a session; choose a new --out folder (or append after `recover`)");
    }
    // Nothing was recorded in it: start the creation again.
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(dir / (std::string(kSessionDatabaseName) + suffix));
  }
  CreateDirectoryDurably(dir / "frames");
  auto db = OpenDatabase(dir, Database::Mode::kCreate);
  {
    Transaction transaction(*db);
    db->Prepare(
          "INSERT INTO session(id, name, latitude_deg, longitude_deg, height_m, rig_config, software_version, clock, "
          "created_utc_ns) VALUES(1, ?, ?, ?, ?, ?, ?, ?, ?)")
        .Bind(1, info.name)
        .Bind(2, info.site.latitude_deg())
        .Bind(3, info.site.longitude_deg())
        .Bind(4, info.site.height_m)
        .Bind(5, info.rig_config)
        .Bind(6, info.software_version)
        .Bind(7, info.clock_name)
        .Bind(8, Ns(info.created_utc))
        .Run();
    transaction.Commit();
  }
  SyncDirectory(dir);
  return std::unique_ptr<SessionWriter>(new SessionWriter(dir, std::move(db), info.site, options, std::move(lock)));
}

std::unique_ptr<SessionWriter> SessionWriter::Append(const fs::path& dir, const SessionWriterOptions& options) {
  const SessionReader reader(dir);
  FolderLock lock = FolderLock::Acquire(dir, "session writer");
  auto db = OpenDatabase(dir, Database::Mode::kReadWrite);
  return std::unique_ptr<SessionWriter>(
      new SessionWriter(dir, std::move(db), reader.info().site, options, std::move(lock)));
}

void SessionWriter::AddDevice(const drivers::DeviceInfo& device) {
  nlohmann::json details = device.details;
  db_->Prepare(
         "INSERT OR REPLACE INTO devices(full_id, backend, kind, model, serial, address, details_json) "
         "VALUES(?, ?, ?, ?, ?, ?, ?)")
      .Bind(1, device.FullId())
      .Bind(2, device.backend)
      .Bind(3, std::string(drivers::ToString(device.kind)))
      .Bind(4, device.model)
      .Bind(5, device.serial)
      .Bind(6, device.address)
      .Bind(7, details.dump())
      .Run();
}

std::int64_t SessionWriter::BeginBracket(const std::string& device_id, UtcTime started_utc, int planned_count) {
  db_->Prepare("INSERT INTO brackets(device_id, started_utc_ns, planned_count, status) VALUES(?, ?, ?, 'open')")
      .Bind(1, device_id)
      .Bind(2, Ns(started_utc))
      .Bind(3, std::int64_t{planned_count})
      .Run();
  return db_->LastInsertId();
}

void SessionWriter::EndBracket(std::int64_t bracket_id, const std::string& status, const std::string& reason) {
  db_->Prepare("UPDATE brackets SET status = ?, reason = ? WHERE id = ?")
      .Bind(1, status)
      .Bind(2, reason)
      .Bind(3, bracket_id)
      .Run();
}

void SessionWriter::InjectStorageFaults(const fs::path& path, std::size_t size) const {
  const StorageFaultPlan& faults = options_.storage_faults;
  if (faults.slow_write_ms > 0.0) {
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(faults.slow_write_ms));
  }
  if (faults.full_after_mb > 0.0 && static_cast<double>(bytes_written_ + size) > faults.full_after_mb * 1048576.0) {
    // Worded as WriteFileDurably words a real ENOSPC, so that callers and users see one message.
    throw IoError(path.string(),
                  "cannot write: No space left on device (simulated by the rig's storage_faults) (the "
                  "disk is full: free space or choose another --out folder; frames already "
                  "acknowledged are safe)");
  }
}

FrameRecord SessionWriter::StoreFile(FrameRecord record, std::span<const std::uint8_t> bytes, bool sync_folder) {
  const fs::path folder = dir_ / "frames" / Slug(record.device_id);
  if (!fs::exists(folder)) CreateDirectoryDurably(folder);
  fs::path relative;
  do {
    ++file_counter_;
    char name[96];
    std::snprintf(name, sizeof(name), "%08lld_%s.%s", static_cast<long long>(file_counter_), record.stream.c_str(),
                  record.file_format.c_str());
    relative = fs::path("frames") / Slug(record.device_id) / name;
  } while (fs::exists(dir_ / relative));
  InjectStorageFaults(dir_ / relative, bytes.size());
  WriteFileDurably(dir_ / relative, bytes, sync_folder);
  bytes_written_ += bytes.size();
  record.file_path = relative.generic_string();
  record.sha256 = Sha256Hex(bytes);
  const SunPosition sun = sun_.At(record.utc);
  record.sun_azimuth_deg = RadToDeg(sun.azimuth_rad);
  record.sun_elevation_deg = RadToDeg(sun.elevation_rad);
  record.sun_algorithm = kSunAlgorithmName;
  return record;
}

void SessionWriter::InsertFrame(FrameRecord& r) {
  Statement insert = db_->Prepare(
      "INSERT INTO frames(device_id, stream, bracket_id, bracket_index, utc_ns, monotonic_ns, device_timestamp_ns, "
      "sequence, exposure_time_s, ev_compensation, aperture_f, iso, gain_db, file_path, sha256, file_format, layout, "
      "encoding, bits_per_sample, black_level, white_level, width, height, sun_azimuth_deg, sun_elevation_deg, "
      "sun_algorithm, sensor_temperature_c) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, "
      "?, "
      "?, ?, ?, ?)");
  std::optional<std::int64_t> device_ts;
  if (r.device_timestamp) device_ts = r.device_timestamp->count();
  insert.Bind(1, r.device_id)
      .Bind(2, r.stream)
      .Bind(3, r.bracket_id)
      .Bind(4, std::int64_t{r.bracket_index})
      .Bind(5, Ns(r.utc))
      .Bind(6, Ns(r.monotonic))
      .Bind(7, device_ts)
      .Bind(8, static_cast<std::int64_t>(r.sequence))
      .Bind(9, r.exposure.exposure_time_s)
      .Bind(10, r.exposure.ev_compensation)
      .Bind(11, r.exposure.aperture_f)
      .Bind(12, r.exposure.iso)
      .Bind(13, r.exposure.gain_db)
      .Bind(14, r.file_path)
      .Bind(15, r.sha256)
      .Bind(16, r.file_format)
      .Bind(17, std::string(ToString(r.layout)))
      .Bind(18, std::string(ToString(r.encoding)))
      .Bind(19, std::int64_t{r.bits_per_sample})
      .Bind(20, std::int64_t{r.black_level})
      .Bind(21, std::int64_t{r.white_level})
      .Bind(22, std::int64_t{r.width})
      .Bind(23, std::int64_t{r.height})
      .Bind(24, r.sun_azimuth_deg)
      .Bind(25, r.sun_elevation_deg)
      .Bind(26, r.sun_algorithm)
      .Bind(27, r.sensor_temperature_c)
      .Run();
  r.id = db_->LastInsertId();
}

namespace {
FrameRecord RecordFromImage(const std::string& device_id, const std::string& stream, const CameraImage& image,
                            const drivers::FrameTiming& timing) {
  FrameRecord r;
  r.device_id = device_id;
  r.stream = stream;
  r.utc = timing.host_utc;
  r.monotonic = timing.host_monotonic;
  r.device_timestamp = timing.device_timestamp;
  r.sequence = timing.sequence;
  r.layout = image.layout;
  r.encoding = image.encoding;
  r.bits_per_sample = image.bits_per_sample;
  r.black_level = image.black_level;
  r.white_level = image.white_level;
  r.width = image.width();
  r.height = image.height();
  return r;
}
}  // namespace

FrameRecord SessionWriter::WriteStillFrame(const drivers::StillFrame& frame, std::optional<std::int64_t> bracket_id,
                                           int bracket_index) {
  std::string why;
  const bool decoded = frame.image.IsValid(&why);
  if (!decoded && frame.original_file.empty()) {
    throw InvalidArgumentError("frame from " + frame.device_id + " has invalid pixels and no camera file: " + why);
  }
  FrameRecord record;
  if (decoded) {
    record = RecordFromImage(frame.device_id, "still", frame.image, frame.timing);
  } else {
    // The camera's file without pixels: what is known without decoding it.
    record = RecordFromImage(frame.device_id, "still", CameraImage{}, frame.timing);
    record.layout = ColorLayout::kMono;
    record.encoding =
        IsRawFormat(frame.original_format) ? SampleEncoding::kSensorLinear : SampleEncoding::kCameraResponse;
    record.bits_per_sample = 0;
    record.white_level = 0;
  }
  record.bracket_id = bracket_id;
  record.bracket_index = bracket_index;
  record.exposure = frame.exposure;
  record.sensor_temperature_c = frame.sensor_temperature_c;
  std::vector<std::uint8_t> encoded;
  std::span<const std::uint8_t> bytes;
  if (!frame.original_file.empty()) {
    record.file_format = frame.original_format.empty() ? "bin" : frame.original_format;
    bytes = frame.original_file;  // the camera's own file, byte for byte
  } else {
    record.file_format = frame.image.pixels.depth() == CV_8U ? "png" : "tiff";
    encoded = Encode(frame.image.pixels, "." + record.file_format);
    bytes = encoded;
  }
  record = StoreFile(std::move(record), bytes);
  Transaction transaction(*db_);
  InsertFrame(record);
  transaction.Commit();
  return record;
}

namespace {
// Depth as 16-bit millimetres; NaN, non-positive and out-of-range values become 0 (none).
cv::Mat DepthMillimetres(const cv::Mat& depth_m) {
  cv::Mat depth_mm(depth_m.size(), CV_16UC1);
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* in = depth_m.ptr<float>(y);
    std::uint16_t* out = depth_mm.ptr<std::uint16_t>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      const float mm = in[x] * 1000.0f;
      out[x] = (std::isfinite(mm) && mm >= 0.5f && mm < 65535.5f) ? static_cast<std::uint16_t>(std::lround(mm)) : 0;
    }
  }
  return depth_mm;
}

// Depth as 32-bit float metres; every value that is not a positive finite distance becomes NaN.
cv::Mat DepthMetres(const cv::Mat& depth_m) {
  cv::Mat out(depth_m.size(), CV_32FC1);
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* in = depth_m.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) o[x] = std::isfinite(in[x]) && in[x] > 0.0f ? in[x] : NAN;
  }
  return out;
}

// OpenCV reads and writes OpenEXR only when OPENCV_IO_ENABLE_OPENEXR is set (off by default
// in current releases); a user's explicit setting wins. Must run before the process's first EXR call:
// OpenCV reads the variable once.
void AllowOpenExr() {
  setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);
}
}  // namespace

std::pair<FrameRecord, FrameRecord> SessionWriter::WriteRgbdFrame(const drivers::RgbdFrame& frame) {
  return WriteRgbdFrames(std::span(&frame, 1)).front();
}

std::vector<std::pair<FrameRecord, FrameRecord>> SessionWriter::WriteRgbdFrames(
    std::span<const drivers::RgbdFrame> frames) {
  // Records and images: depth then colour for each frame.
  std::vector<FrameRecord> records;
  std::vector<cv::Mat> images;
  for (const drivers::RgbdFrame& frame : frames) {
    const bool png = options_.rgbd_format == RgbdFileFormat::kPng;
    const bool metres = options_.depth_units == DepthUnits::kMetres;
    CameraImage depth_image;
    depth_image.pixels = metres ? DepthMetres(frame.depth_m) : DepthMillimetres(frame.depth_m);
    depth_image.layout = ColorLayout::kMono;
    depth_image.encoding = SampleEncoding::kSensorLinear;
    depth_image.bits_per_sample = metres ? 32 : 16;
    depth_image.white_level = metres ? 0 : 65535;
    FrameRecord depth = RecordFromImage(frame.device_id, "depth", depth_image, frame.depth_timing);
    depth.file_format = !png ? "tiff" : metres ? "exr" : "png";  // PNG has no float samples
    if (depth.file_format == "exr") AllowOpenExr();
    FrameRecord color = RecordFromImage(frame.device_id, "color", frame.color, frame.color_timing);
    color.exposure = frame.color_exposure;
    color.file_format = png && frame.color.pixels.depth() == CV_8U ? "png" : "tiff";
    records.push_back(std::move(depth));
    images.push_back(depth_image.pixels);
    records.push_back(std::move(color));
    images.push_back(frame.color.pixels);
  }
  // Encoding dominates the cost of a frame: encode every image of the batch in parallel.
  std::vector<std::vector<std::uint8_t>> encoded(images.size());
  std::vector<std::string> failed(images.size());
  // A frame's recorded file (k even: depth, odd: colour), when it is stored as it is: a colour
  // file always, a depth file only in the format and units this writer stores depth in.
  const double depth_samples_per_metre = options_.depth_units == DepthUnits::kMetres ? 1.0 : 1000.0;
  std::vector<const drivers::RecordedFile*> kept(records.size(), nullptr);
  for (std::size_t k = 0; k < records.size(); ++k) {
    const drivers::RecordedFile& file = k % 2 == 0 ? frames[k / 2].depth_file : frames[k / 2].color_file;
    if (file.bytes.empty()) continue;
    if (k % 2 == 0 &&
        (file.format != records[k].file_format || file.depth_samples_per_metre != depth_samples_per_metre)) {
      continue;
    }
    kept[k] = &file;
    records[k].file_format = file.format;
  }
  cv::parallel_for_(cv::Range(0, static_cast<int>(images.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (kept[k] != nullptr) continue;
      try {
        encoded[k] =
            records[k].file_format == "tiff" ? EncodeTiff(images[k]) : Encode(images[k], "." + records[k].file_format);
      } catch (const Error& e) {
        failed[k] = e.what();
      }
    }
  });
  for (const std::string& f : failed) {
    if (!f.empty()) throw IoError(records.front().device_id, f);
  }
  std::set<fs::path> folders;
  for (std::size_t k = 0; k < records.size(); ++k) {
    records[k] =
        StoreFile(std::move(records[k]), kept[k] != nullptr ? kept[k]->bytes : encoded[k], /*sync_folder=*/false);
    folders.insert((dir_ / records[k].file_path).parent_path());
  }
  for (const fs::path& folder : folders) SyncDirectory(folder);  // the renames are durable before the rows
  Transaction transaction(*db_);
  std::map<std::string, std::string> new_geometry;
  std::vector<std::pair<FrameRecord, FrameRecord>> out;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    FrameRecord& depth = records[2 * i];
    FrameRecord& color = records[2 * i + 1];
    InsertFrame(depth);
    InsertFrame(color);
    const std::string geometry = RgbdGeometryToJson(frames[i]);
    const auto in_batch = new_geometry.find(frames[i].device_id);
    const auto known = rgbd_geometry_.find(frames[i].device_id);
    const std::string* last = in_batch != new_geometry.end()  ? &in_batch->second
                              : known != rgbd_geometry_.end() ? &known->second
                                                              : nullptr;
    if (!last || *last != geometry) {
      AddCalibration(
          {0, frames[i].depth_timing.host_utc, kRgbdGeometryKind, frames[i].device_id, geometry, {depth.id, color.id}});
      new_geometry[frames[i].device_id] = geometry;
    }
    out.emplace_back(depth, color);
  }
  transaction.Commit();
  for (auto& [device, geometry] : new_geometry) rgbd_geometry_[device] = geometry;
  return out;
}

std::int64_t SessionWriter::AddEvent(const EventRecord& event) {
  db_->Prepare("INSERT INTO events(utc_ns, monotonic_ns, device_id, type, message) VALUES(?, ?, ?, ?, ?)")
      .Bind(1, Ns(event.utc))
      .Bind(2, Ns(event.monotonic))
      .Bind(3, event.device_id)
      .Bind(4, event.type)
      .Bind(5, event.message)
      .Run();
  return db_->LastInsertId();
}

std::int64_t SessionWriter::AddCalibration(const CalibrationRecord& calibration) {
  nlohmann::json sources = calibration.source_frame_ids;
  db_->Prepare(
         "INSERT INTO calibrations(created_utc_ns, kind, device_id, json, source_frame_ids) VALUES(?, ?, ?, ?, ?)")
      .Bind(1, Ns(calibration.created_utc))
      .Bind(2, calibration.kind)
      .Bind(3, calibration.device_id)
      .Bind(4, calibration.json)
      .Bind(5, sources.dump())
      .Run();
  return db_->LastInsertId();
}

SessionReader::SessionReader(const fs::path& dir) : dir_(dir) {
  if (!fs::exists(dir / kSessionDatabaseName)) {
    throw IoError(dir.string(), "no session here (no " + std::string(kSessionDatabaseName) + ")");
  }
  db_ = OpenDatabase(dir, Database::Mode::kReadOnly);
  Statement s = db_->Prepare(
      "SELECT name, latitude_deg, longitude_deg, height_m, rig_config, software_version, clock, created_utc_ns "
      "FROM session WHERE id = 1");
  if (!s.Step()) {
    throw IoError(dir.string(),
                  "the session database has no session row: the session was never completely created (e.g. the "
                  "disk filled or the capture was stopped while creating it), so nothing was recorded in it; "
                  "capture again into this folder (relume replaces the empty database) or delete it");
  }
  info_.name = s.Text(0);
  info_.site = Site{DegToRad(s.Double(1)), DegToRad(s.Double(2)), s.Double(3)};
  info_.rig_config = s.Text(4);
  info_.software_version = s.Text(5);
  info_.clock_name = s.Text(6);
  info_.created_utc = UtcTime(Nanoseconds(s.Int(7)));
}

std::vector<drivers::DeviceInfo> SessionReader::Devices() const {
  std::vector<drivers::DeviceInfo> devices;
  Statement s = db_->Prepare("SELECT backend, full_id, kind, model, serial, address, details_json FROM devices");
  while (s.Step()) {
    drivers::DeviceInfo d;
    d.backend = s.Text(0);
    const std::string full_id = s.Text(1);
    if (!full_id.starts_with(d.backend + ":")) {
      throw IoError(db_->path(), "devices row '" + full_id + "' does not start with its backend '" + d.backend +
                                     ":': the database is damaged");
    }
    d.id = full_id.substr(d.backend.size() + 1);
    d.kind = s.Text(2) == "rgbd_sensor" ? drivers::DeviceKind::kRgbdSensor : drivers::DeviceKind::kStillCamera;
    d.model = s.Text(3);
    d.serial = s.Text(4);
    d.address = s.Text(5);
    d.details =
        ParseColumn<std::map<std::string, std::string>>(*db_, s.Text(6), "devices.details_json of " + d.FullId());
    devices.push_back(d);
  }
  return devices;
}

std::vector<FrameRecord> SessionReader::Frames() const {
  std::vector<FrameRecord> frames;
  Statement s = db_->Prepare(
      "SELECT id, device_id, stream, bracket_id, bracket_index, utc_ns, monotonic_ns, device_timestamp_ns, sequence, "
      "exposure_time_s, ev_compensation, aperture_f, iso, gain_db, file_path, sha256, file_format, layout, encoding, "
      "bits_per_sample, black_level, white_level, width, height, sun_azimuth_deg, sun_elevation_deg, sun_algorithm, "
      "sensor_temperature_c FROM frames ORDER BY id");
  while (s.Step()) {
    FrameRecord r;
    r.id = s.Int(0);
    r.device_id = s.Text(1);
    r.stream = s.Text(2);
    if (!s.IsNull(3)) r.bracket_id = s.Int(3);
    r.bracket_index = static_cast<int>(s.Int(4));
    r.utc = UtcTime(Nanoseconds(s.Int(5)));
    r.monotonic = MonotonicTime(Nanoseconds(s.Int(6)));
    if (!s.IsNull(7)) r.device_timestamp = Nanoseconds(s.Int(7));
    r.sequence = static_cast<std::uint64_t>(s.Int(8));
    r.exposure.exposure_time_s = s.Double(9);
    r.exposure.ev_compensation = s.IsNull(10) ? 0.0 : s.Double(10);
    r.exposure.aperture_f = s.Double(11);
    r.exposure.iso = s.Double(12);
    r.exposure.gain_db = s.Double(13);
    r.file_path = s.Text(14);
    r.sha256 = s.Text(15);
    r.file_format = s.Text(16);
    r.layout = ParseLayout(s.Text(17));
    r.encoding = ParseEncoding(s.Text(18));
    r.bits_per_sample = static_cast<int>(s.Int(19));
    r.black_level = static_cast<int>(s.Int(20));
    r.white_level = static_cast<int>(s.Int(21));
    r.width = static_cast<int>(s.Int(22));
    r.height = static_cast<int>(s.Int(23));
    r.sun_azimuth_deg = s.Double(24);
    r.sun_elevation_deg = s.Double(25);
    r.sun_algorithm = s.Text(26);
    if (!s.IsNull(27)) r.sensor_temperature_c = s.Double(27);
    frames.push_back(std::move(r));
  }
  return frames;
}

std::vector<BracketRecord> SessionReader::Brackets() const {
  std::vector<BracketRecord> brackets;
  Statement s =
      db_->Prepare("SELECT id, device_id, started_utc_ns, planned_count, status, reason FROM brackets ORDER BY id");
  while (s.Step()) {
    brackets.push_back(
        {s.Int(0), s.Text(1), UtcTime(Nanoseconds(s.Int(2))), static_cast<int>(s.Int(3)), s.Text(4), s.Text(5)});
  }
  return brackets;
}

std::vector<EventRecord> SessionReader::Events() const {
  std::vector<EventRecord> events;
  Statement s = db_->Prepare("SELECT id, utc_ns, monotonic_ns, device_id, type, message FROM events ORDER BY id");
  while (s.Step()) {
    events.push_back({s.Int(0), UtcTime(Nanoseconds(s.Int(1))), MonotonicTime(Nanoseconds(s.Int(2))), s.Text(3),
                      s.Text(4), s.Text(5)});
  }
  return events;
}

std::vector<CalibrationRecord> SessionReader::Calibrations() const {
  std::vector<CalibrationRecord> calibrations;
  Statement s =
      db_->Prepare("SELECT id, created_utc_ns, kind, device_id, json, source_frame_ids FROM calibrations ORDER BY id");
  while (s.Step()) {
    CalibrationRecord c;
    c.id = s.Int(0);
    c.created_utc = UtcTime(Nanoseconds(s.Int(1)));
    c.kind = s.Text(2);
    c.device_id = s.Text(3);
    c.json = s.Text(4);
    c.source_frame_ids = ParseColumn<std::vector<std::int64_t>>(
        *db_, s.Text(5), "calibrations.source_frame_ids of calibration " + std::to_string(c.id));
    calibrations.push_back(std::move(c));
  }
  return calibrations;
}

std::vector<std::uint8_t> SessionReader::ReadFrameFile(const FrameRecord& frame, bool verify_checksum) const {
  const fs::path path = SessionFilePath(dir_, frame.file_path, "frame " + std::to_string(frame.id));
  std::vector<std::uint8_t> bytes;
  try {
    bytes = ReadRegularFile(path);
  } catch (const IoError& e) {
    throw IoError(path.string(),
                  "frame " + std::to_string(frame.id) + " " + e.reason() + " (run `relume session verify`)");
  }
  if (verify_checksum && Sha256Hex(bytes) != frame.sha256) {
    throw IoError(path.string(), "checksum mismatch: the file changed after it was recorded");
  }
  return bytes;
}

namespace {
cv::Mat DecodeStoredImage(std::span<const std::uint8_t> bytes, const FrameRecord& frame, const std::string& name) {
  if (frame.file_format != "png" && frame.file_format != "tiff" && frame.file_format != "jpeg" &&
      frame.file_format != "jpg" && frame.file_format != "exr") {
    throw InvalidArgumentError(name + ": '" + frame.file_format +
                               "' files are camera raw; decode them with the calibration layer's raw loader");
  }
  if (frame.file_format == "exr") AllowOpenExr();
  cv::Mat pixels = DecodeWithOpenCv(bytes, name);
  if (pixels.channels() == 3) cv::cvtColor(pixels, pixels, cv::COLOR_BGR2RGB);
  return pixels;
}
}  // namespace

CameraImage DecodeFrameImage(std::span<const std::uint8_t> bytes, const FrameRecord& frame, const std::string& name) {
  const std::string& format = frame.file_format;
  if (IsRawFormat(format)) {
    try {
      return DecodeRawFile(bytes, name).image;
    } catch (const InvalidArgumentError& e) {  // a sensor layout relume does not process
      throw IoError(name, std::string("relume cannot process this camera raw file (the file itself is kept "
                                      "intact): ") +
                              e.what());
    } catch (const Error& e) {  // LibRaw does not know the format
      throw IoError(name, std::string("relume cannot decode this camera raw file (the file itself is kept intact): ") +
                              e.what() + ". A DNG converter that knows the camera makes a file LibRaw reads");
    }
  }
  if (format != "png" && format != "tiff" && format != "jpeg" && format != "jpg") {
    throw IoError(name, "'" + format + "' files cannot be decoded by relume (the file itself is kept intact)");
  }
  CameraImage image;
  image.pixels = DecodeWithOpenCv(bytes, name);
  if (image.pixels.channels() == 4) cv::cvtColor(image.pixels, image.pixels, cv::COLOR_BGRA2RGB);
  if (image.pixels.channels() == 3) cv::cvtColor(image.pixels, image.pixels, cv::COLOR_BGR2RGB);
  image.layout = frame.layout;
  image.encoding = frame.encoding;
  image.bits_per_sample = frame.bits_per_sample;
  image.black_level = frame.black_level;
  image.white_level = frame.white_level;
  return image;
}

CameraImage SessionReader::LoadImage(const FrameRecord& frame, bool verify_checksum) const {
  return DecodeFrameImage(ReadFrameFile(frame, verify_checksum), frame, (dir_ / frame.file_path).string());
}

cv::Mat DecodeDepthFrame(std::span<const std::uint8_t> bytes, const FrameRecord& frame, const std::string& name,
                         double* samples_per_metre) {
  const cv::Mat mm = DecodeStoredImage(bytes, frame, name);
  if (mm.type() == CV_32FC1) {  // stored in metres (`rgbd_depth: metres`)
    if (samples_per_metre != nullptr) *samples_per_metre = 1.0;
    return DepthMetres(mm);
  }
  if (mm.type() != CV_16UC1) {
    throw IoError(name, "depth file is neither 16-bit millimetres nor 32-bit float metres (one channel)");
  }
  if (samples_per_metre != nullptr) *samples_per_metre = 1000.0;
  cv::Mat depth_m(mm.size(), CV_32FC1);
  for (int y = 0; y < mm.rows; ++y) {
    const std::uint16_t* in = mm.ptr<std::uint16_t>(y);
    float* out = depth_m.ptr<float>(y);
    for (int x = 0; x < mm.cols; ++x) out[x] = in[x] == 0 ? NAN : static_cast<float>(in[x]) * 0.001f;
  }
  return depth_m;
}

cv::Mat SessionReader::LoadDepth(const FrameRecord& frame, bool verify_checksum) const {
  return DecodeDepthFrame(ReadFrameFile(frame, verify_checksum), frame, (dir_ / frame.file_path).string());
}

}  // namespace relume::capture
