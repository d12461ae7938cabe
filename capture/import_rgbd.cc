#include "capture/import_rgbd.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>

#include "capture/durable_file.h"
#include "capture/folder_lock.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/input_file.h"
#include "drivers/device_error.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;

// The row's file_format of a colour or depth file; empty for what the import does not read.
std::string FormatOf(const fs::path& file) {
  const std::string format = FileFormatOf(file);
  return format == "png" || format == "jpeg" ? format : "";
}

// "1305031102.175304" as an exact UtcTime; nullopt when it is not a non-negative decimal number.
std::optional<UtcTime> ParseUnixTime(const std::string& text) {
  const std::size_t dot = text.find('.');
  const std::string whole = text.substr(0, dot);
  std::string fraction = dot == std::string::npos ? "" : text.substr(dot + 1);
  const auto digits = [](const std::string& s) {
    return std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
  };
  if (whole.empty() || whole.size() > 12 || !digits(whole) || !digits(fraction)) return std::nullopt;
  if (fraction.size() > 9) fraction.resize(9);  // below a nanosecond
  fraction.resize(9, '0');
  return UtcTime(std::chrono::seconds(std::stoll(whole)) + Nanoseconds(std::stoll(fraction)));
}

std::string Size(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows);
}

// A colour file decoded to RGB with its row's pixel fields. Throws InvalidArgumentError naming
// the file when it is not 8- or 16-bit colour.
CameraImage DecodeColor(const std::vector<std::uint8_t>& bytes, const fs::path& path) {
  const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  if (decoded.empty() || (decoded.depth() != CV_8U && decoded.depth() != CV_16U) ||
      (decoded.channels() != 3 && decoded.channels() != 4)) {
    throw InvalidArgumentError(path.string() +
                               ": not an 8- or 16-bit colour PNG or JPEG (the colour frames of an RGB-D import)");
  }
  CameraImage image;
  cv::cvtColor(decoded, image.pixels, decoded.channels() == 4 ? cv::COLOR_BGRA2RGB : cv::COLOR_BGR2RGB);
  image.layout = ColorLayout::kRgb;
  image.encoding = SampleEncoding::kCameraResponse;
  const bool sixteen = decoded.depth() == CV_16U;
  image.bits_per_sample = sixteen ? 16 : 8;
  image.black_level = 0;
  image.white_level = sixteen ? 65535 : 255;
  return image;
}

// A depth file in metres (NaN where it holds 0). Throws InvalidArgumentError naming the file when
// it is not a 16-bit single-channel PNG.
cv::Mat DecodeDepth(const std::vector<std::uint8_t>& bytes, const fs::path& path, double units_per_metre) {
  const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  if (decoded.empty() || decoded.type() != CV_16UC1) {
    throw InvalidArgumentError(path.string() +
                               ": not a 16-bit single-channel PNG (the depth frames of an RGB-D import hold the "
                               "depth times --depth-scale, 0 where there is none)");
  }
  cv::Mat depth_m(decoded.size(), CV_32FC1);
  for (int y = 0; y < decoded.rows; ++y) {
    const std::uint16_t* in = decoded.ptr<std::uint16_t>(y);
    float* out = depth_m.ptr<float>(y);
    for (int x = 0; x < decoded.cols; ++x) {
      out[x] = in[x] == 0 ? NAN : static_cast<float>(static_cast<double>(in[x]) / units_per_metre);
    }
  }
  return depth_m;
}

struct Pair {
  std::size_t depth = 0, color = 0;  // indices into the lists
};

// Each depth frame with the nearest colour frame within `max_gap`, each colour frame used once:
// candidates taken in order of their gap (associate.py of the TUM benchmark). Sorted by depth time.
std::vector<Pair> Associate(const std::vector<RgbdListEntry>& depth, const std::vector<RgbdListEntry>& color,
                            Nanoseconds max_gap) {
  std::vector<std::pair<Nanoseconds, Pair>> candidates;
  std::vector<std::size_t> color_order(color.size());
  for (std::size_t i = 0; i < color.size(); ++i) color_order[i] = i;
  std::stable_sort(color_order.begin(), color_order.end(),
                   [&](std::size_t a, std::size_t b) { return color[a].utc < color[b].utc; });
  for (std::size_t d = 0; d < depth.size(); ++d) {
    auto it = std::lower_bound(color_order.begin(), color_order.end(), depth[d].utc - max_gap,
                               [&](std::size_t c, UtcTime t) { return color[c].utc < t; });
    for (; it != color_order.end() && color[*it].utc <= depth[d].utc + max_gap; ++it) {
      candidates.push_back({std::chrono::abs(color[*it].utc - depth[d].utc), Pair{d, *it}});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<bool> depth_used(depth.size()), color_used(color.size());
  std::vector<Pair> pairs;
  for (const auto& [gap, p] : candidates) {
    if (depth_used[p.depth] || color_used[p.color]) continue;
    depth_used[p.depth] = color_used[p.color] = true;
    pairs.push_back(p);
  }
  std::stable_sort(pairs.begin(), pairs.end(),
                   [&](const Pair& a, const Pair& b) { return depth[a.depth].utc < depth[b.depth].utc; });
  return pairs;
}

// What can be told of a pair without reading its files: their formats, and that they exist.
// Throws InvalidArgumentError (format) or IoError (no such file) naming the file.
void CheckPairFiles(const RgbdImportOptions& options, const RgbdListEntry& depth, const RgbdListEntry& color) {
  const fs::path depth_path = options.folder / depth.file, color_path = options.folder / color.file;
  if (FormatOf(depth.file) != "png") {
    throw InvalidArgumentError(depth_path.string() + ": depth frames must be 16-bit PNG files");
  }
  if (FormatOf(color.file).empty()) {
    throw InvalidArgumentError(color_path.string() + ": colour frames must be PNG or JPEG files");
  }
  for (const auto& [path, list] : {std::pair{depth_path, "depth.txt"}, std::pair{color_path, "rgb.txt"}}) {
    std::error_code error;
    if (!fs::is_regular_file(path, error)) {
      throw IoError(path.string(), std::string("is listed in ") + list +
                                       " but is not a readable file: correct the list or restore the file");
    }
  }
}

// The pair's frame for SessionWriter, with its files (depth_file, color_file) as recorded. The
// pair has passed CheckPairFiles (a file gone since is an IoError from reading it).
drivers::RgbdFrame LoadPair(const RgbdImportOptions& options, const RgbdListEntry& depth, const RgbdListEntry& color,
                            const PinholeIntrinsics& intrinsics) {
  const fs::path depth_path = options.folder / depth.file, color_path = options.folder / color.file;
  drivers::RgbdFrame frame;
  frame.depth_file = {ReadInputBytes(depth_path), "png", options.depth_units_per_metre};
  frame.color_file = {ReadInputBytes(color_path), FormatOf(color.file), 0.0};
  frame.depth_m = DecodeDepth(frame.depth_file.bytes, depth_path, options.depth_units_per_metre);
  frame.color = DecodeColor(frame.color_file.bytes, color_path);
  if (frame.color.pixels.cols != intrinsics.width || frame.color.pixels.rows != intrinsics.height) {
    throw InvalidArgumentError(color_path.string() + " is " + Size(frame.color.pixels) + " but the colour camera is " +
                               std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height) +
                               " (--intrinsics' size, or the first colour frame's): a recording has one size");
  }
  if (frame.depth_m.size() != frame.color.pixels.size()) {
    throw InvalidArgumentError(depth_path.string() + " is " + Size(frame.depth_m) + " but its colour frame " +
                               color_path.string() + " is " + Size(frame.color.pixels) +
                               ": relume needs depth registered to colour (the colour camera's viewpoint and size); "
                               "register it first, e.g. with OpenNI's image registration or librealsense's align");
  }
  frame.depth_intrinsics = intrinsics;
  frame.color_intrinsics = intrinsics;
  frame.registered_to_color = true;
  frame.color_exposure.exposure_time_s = options.exposure_time_s;
  frame.color_exposure.iso = options.iso;
  return frame;
}

drivers::FrameTiming Timing(UtcTime utc, UtcTime first, std::uint64_t sequence) {
  drivers::FrameTiming t;
  t.host_utc = utc;
  t.host_monotonic = MonotonicTime(utc - first);
  t.device_timestamp = utc.time_since_epoch();
  t.sequence = sequence;
  return t;
}

// A new session in `out` holding one imported RGB-D device; sets *device.
std::unique_ptr<SessionWriter> CreateRgbdSession(const fs::path& out, const std::string& name, const Site& site,
                                                 const std::string& camera_id, const std::string& model,
                                                 const std::string& clock, bool depth_in_metres,
                                                 drivers::DeviceInfo* device) {
  device->backend = "import";
  device->id = camera_id;
  device->kind = drivers::DeviceKind::kRgbdSensor;
  device->model = model;
  device->address = "files";
  SessionInfo info;
  info.name = name.empty() ? out.filename().string() : name;
  info.site = site;
  info.software_version = "relume import";
  info.clock_name = clock;
  info.created_utc = UtcNow();
  SessionWriterOptions writer_options;
  writer_options.rgbd_format = RgbdFileFormat::kPng;
  writer_options.depth_units = depth_in_metres ? DepthUnits::kMetres : DepthUnits::kMillimetres;
  std::unique_ptr<SessionWriter> writer = SessionWriter::Create(out, info, writer_options);
  writer->AddDevice(*device);
  return writer;
}

void Note(SessionWriter& writer, const std::string& device_id, const std::string& message) {
  writer.AddEvent({0, UtcNow(), MonotonicNow(), device_id, "note", message});
}

// Removes what an import made in `out` when the import fails after its session was created:
// the folder when it did not exist before, else the session's database and frames folder when
// they did not. Never what was there before (another session's database: SessionWriter::Create
// refuses it, and nothing is removed). For imports of files that stay where they are: a failed
// import then loses nothing, leaves nothing to clean up, and the same --out works again.
// Construct it before creating the session, Arm() it once created, Keep() it once the import
// has ended, and destroy the session's writer before it.
class RemoveUnlessKept {
 public:
  explicit RemoveUnlessKept(fs::path out)
      : out_(std::move(out)),
        made_folder_(!fs::exists(out_)),
        made_database_(!fs::exists(out_ / kSessionDatabaseName)),
        made_frames_(!fs::exists(out_ / "frames")),
        made_lock_(!fs::exists(out_ / kLockFileName)) {}
  RemoveUnlessKept(const RemoveUnlessKept&) = delete;
  RemoveUnlessKept& operator=(const RemoveUnlessKept&) = delete;
  ~RemoveUnlessKept() {
    if (!armed_) return;
    std::error_code ignored;  // a destructor on an exception's way: best effort, never throws
    if (made_folder_) {
      fs::remove_all(out_, ignored);
      return;
    }
    if (made_database_) {
      for (const char* suffix : {"", "-wal", "-shm"})
        fs::remove(out_ / (std::string(kSessionDatabaseName) + suffix), ignored);
    }
    if (made_frames_) fs::remove_all(out_ / "frames", ignored);
    if (made_lock_) fs::remove(out_ / kLockFileName, ignored);
  }
  void Arm() { armed_ = true; }
  void Keep() { armed_ = false; }

 private:
  fs::path out_;
  bool made_folder_, made_database_, made_frames_, made_lock_;
  bool armed_ = false;
};

}  // namespace

bool RgbdImportOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (folder.empty()) return fail("no RGB-D folder (--rgbd DIR, holding rgb.txt and depth.txt)");
  std::string reason;
  if (!site.IsValid(&reason)) return fail("site: " + reason);
  if (camera_id.empty()) return fail("--camera-id must not be empty");
  const PinholeIntrinsics& k = color_intrinsics;
  if (!(std::isfinite(k.fx) && k.fx > 0.0 && std::isfinite(k.fy) && k.fy > 0.0 && std::isfinite(k.cx) &&
        std::isfinite(k.cy))) {
    return fail("--intrinsics must give the colour camera's fx,fy,cx,cy in pixels (fx, fy > 0)");
  }
  if (k.width < 0 || k.height < 0) return fail("the colour camera's width and height must not be negative");
  if (!(std::isfinite(depth_units_per_metre) && depth_units_per_metre > 0.0)) {
    return fail("--depth-scale must be a positive number (depth values per metre: 1000 for millimetres)");
  }
  if (!(max_pair_gap_s >= 0.0 && max_pair_gap_s <= 10.0)) return fail("--max-pair-gap must be within [0, 10] s");
  for (const auto& [value, flag] : {std::pair{exposure_time_s, "--exposure-time"}, {iso, "--iso"}}) {
    if (!std::isnan(value) && !(std::isfinite(value) && value > 0.0)) {
      return fail(std::string(flag) + " must be a positive number");
    }
  }
  if (frames_per_batch < 1) return fail("frames_per_batch must be at least 1");
  return true;
}

std::string RgbdImportSummary::Report() const {
  std::ostringstream out;
  out << "imported " << pairs << " RGB-D frame pairs of " << device_id << ", " << FormatIso8601(first_utc) << " .. "
      << FormatIso8601(last_utc) << ", " << bytes / 1024 << " KiB -> " << session.string() << "\n";
  out << "  largest depth-colour time gap " << largest_pair_gap_s * 1e3 << " ms\n";
  if (unpaired_color > 0 || unpaired_depth > 0) {
    out << "  not imported (no partner within the gap): " << unpaired_depth << " depth and " << unpaired_color
        << " colour frame(s)\n";
  }
  if (depth_converted) {
    out << "  depth stored as float metres (OpenEXR); the originals' SHA-256 are in the session's events\n";
  }
  for (const std::string& note : notes) out << "  note: " << note << "\n";
  return out.str();
}

std::vector<RgbdListEntry> ReadRgbdList(const fs::path& folder, const std::string& name) {
  const fs::path path = folder / name;
  std::istringstream in(ReadInputFile(path));
  std::vector<RgbdListEntry> entries;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream fields(line);
    std::string stamp, file, extra;
    if (!(fields >> stamp) || stamp.front() == '#') continue;  // blank or comment
    const std::optional<UtcTime> utc = ParseUnixTime(stamp);
    if (!utc || !(fields >> file) || (fields >> extra)) {
      throw InvalidArgumentError(path.string() + " line " + std::to_string(number) + ": '" + line +
                                 "' is not 'TIMESTAMP FILE' (Unix time in seconds, UTC, and a file relative to " +
                                 folder.string() + ")");
    }
    entries.push_back({*utc, fs::path(file)});
  }
  if (entries.empty()) throw InvalidArgumentError(path.string() + " lists no frames");
  return entries;
}

RgbdImportSummary ImportRgbd(const RgbdImportOptions& options, const fs::path& out) {
  ThrowIfInvalid(options, "RGB-D import options");
  const std::vector<RgbdListEntry> color = ReadRgbdList(options.folder, "rgb.txt");
  const std::vector<RgbdListEntry> depth = ReadRgbdList(options.folder, "depth.txt");
  const auto max_gap = std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(options.max_pair_gap_s));
  const std::vector<Pair> pairs = Associate(depth, color, max_gap);
  if (pairs.empty()) {
    throw InvalidArgumentError("no depth frame of " + (options.folder / "depth.txt").string() +
                               " has a colour frame within " + std::to_string(options.max_pair_gap_s * 1e3) +
                               " ms: are both lists in the same clock? (--max-pair-gap widens the window)");
  }
  PinholeIntrinsics intrinsics = options.color_intrinsics;
  if (intrinsics.width == 0 || intrinsics.height == 0) {
    const fs::path first = options.folder / color[pairs.front().color].file;
    const cv::Mat image = DecodeColor(ReadInputBytes(first), first).pixels;
    intrinsics.width = image.cols;
    intrinsics.height = image.rows;
  }
  std::string why;
  if (!intrinsics.IsValid(&why)) throw InvalidArgumentError("--intrinsics: " + why);

  RgbdImportSummary summary;
  summary.session = out;
  summary.pairs = static_cast<int>(pairs.size());
  summary.unpaired_depth = static_cast<int>(depth.size() - pairs.size());
  summary.unpaired_color = static_cast<int>(color.size() - pairs.size());
  summary.depth_converted = options.depth_units_per_metre != 1000.0;
  UtcTime first = UtcTime::max(), last = UtcTime::min();
  for (const Pair& p : pairs) {
    first = std::min({first, depth[p.depth].utc, color[p.color].utc});
    last = std::max({last, depth[p.depth].utc, color[p.color].utc});
    summary.largest_pair_gap_s =
        std::max(summary.largest_pair_gap_s,
                 std::chrono::duration<double>(std::chrono::abs(depth[p.depth].utc - color[p.color].utc)).count());
  }
  summary.first_utc = first;
  summary.last_utc = last;
  // Every pair's files checked before the session exists; each is read and decoded once, as it
  // is stored, and a frame refused then removes the session made so far.
  for (const Pair& p : pairs) CheckPairFiles(options, depth[p.depth], color[p.color]);

  RemoveUnlessKept made(out);
  drivers::DeviceInfo device;
  std::unique_ptr<SessionWriter> writer =
      CreateRgbdSession(out, options.name, options.site, options.camera_id, "RGB-D recording (TUM RGB-D layout)",
                        "the recording's timestamps (rgb.txt, depth.txt)", summary.depth_converted, &device);
  made.Arm();
  summary.device_id = device.FullId();

  const auto batch = static_cast<std::size_t>(options.frames_per_batch);
  for (std::size_t begin = 0; begin < pairs.size(); begin += batch) {
    const std::size_t end = std::min(pairs.size(), begin + batch);
    std::vector<drivers::RgbdFrame> frames;
    for (std::size_t i = begin; i < end; ++i) {
      const RgbdListEntry& d = depth[pairs[i].depth];
      const RgbdListEntry& c = color[pairs[i].color];
      drivers::RgbdFrame frame = LoadPair(options, d, c, intrinsics);
      frame.device_id = device.FullId();
      frame.depth_timing = Timing(d.utc, first, i);
      frame.color_timing = Timing(c.utc, first, i);
      summary.bytes += frame.color_file.bytes.size() + frame.depth_file.bytes.size();
      // Depth in other units than millimetres is stored as float metres (the writer encodes it:
      // the file's units are not the session's); the note below names the original by checksum.
      if (summary.depth_converted) {
        summary.original_depth_sha256.push_back(d.file.generic_string() + " " + Sha256Hex(frame.depth_file.bytes));
      }
      frames.push_back(std::move(frame));
    }
    const std::vector<std::pair<FrameRecord, FrameRecord>> rows = writer->WriteRgbdFrames(frames);
    if (summary.depth_converted) {
      for (std::size_t i = begin; i < end; ++i) {
        Note(*writer, device.FullId(),
             "depth frame " + std::to_string(rows[i - begin].first.id) + " from original " +
                 summary.original_depth_sha256[i] + " (" + std::to_string(options.depth_units_per_metre) +
                 " per metre), stored as float metres");
      }
    }
  }
  Note(*writer, device.FullId(),
       "imported " + std::to_string(summary.pairs) + " RGB-D frame pairs from " + options.folder.string() + " (" +
           std::to_string(summary.unpaired_depth) + " depth and " + std::to_string(summary.unpaired_color) +
           " colour frames without a partner left out)");
  writer.reset();
  made.Keep();
  return summary;
}

bool RgbdStreamImportOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  std::string reason;
  if (!site.IsValid(&reason)) return fail("site: " + reason);
  if (camera_id.empty()) return fail("--camera-id must not be empty");
  if (!start_utc) {
    return fail(
        "the recording's start time is needed (--start 2026-03-20T11:00:00Z): a recording holds only its device's "
        "clock");
  }
  if (frames < 0) return fail("frames must not be negative");
  if (frame_timeout <= std::chrono::milliseconds(0)) return fail("frame_timeout must be positive");
  if (frames_per_batch < 1) return fail("frames_per_batch must be at least 1");
  return true;
}

RgbdImportSummary ImportRgbdStream(drivers::RgbdSensor& sensor, const RgbdStreamImportOptions& options,
                                   const fs::path& out) {
  ThrowIfInvalid(options, "RGB-D stream import options");
  const std::string what = options.source.empty() ? sensor.info().FullId() : options.source;
  std::vector<drivers::RgbdFrame> batch;
  batch.push_back(sensor.WaitForFrame(options.frame_timeout));  // before the session exists
  if (!batch.front().depth_timing.device_timestamp || !batch.front().color_timing.device_timestamp) {
    throw InvalidArgumentError(what + ": its frames carry no device time, so their times cannot be placed");
  }
  const Nanoseconds origin = *batch.front().depth_timing.device_timestamp;
  const UtcTime start = *options.start_utc;

  RgbdImportSummary summary;
  summary.session = out;
  drivers::DeviceInfo device;
  const std::unique_ptr<SessionWriter> writer =
      CreateRgbdSession(out, options.name, options.site, options.camera_id, options.model,
                        "the recording's device clock from the stated start (" + FormatIso8601(start) + ")",
                        /*depth_in_metres=*/false, &device);
  summary.device_id = device.FullId();
  Note(*writer, device.FullId(),
       "importing " + what + (options.source_sha256.empty() ? "" : " (SHA-256 " + options.source_sha256 + ")") +
           ", first frame at " + FormatIso8601(start));
  summary.first_utc = UtcTime::max();
  summary.last_utc = UtcTime::min();
  // Places a frame on the UTC axis (the start plus its device time since the first frame);
  // false when it has no device time.
  const auto place = [&](drivers::RgbdFrame& f) {
    if (!f.depth_timing.device_timestamp || !f.color_timing.device_timestamp) return false;
    if (options.registered) {
      f.registered_to_color = true;
      f.depth_intrinsics = f.color_intrinsics;
      f.color_from_depth = Eigen::Isometry3d::Identity();
    }
    for (drivers::FrameTiming* t : {&f.depth_timing, &f.color_timing}) {
      t->host_utc = start + (*t->device_timestamp - origin);
      t->host_monotonic = MonotonicTime(*t->device_timestamp - origin);
    }
    f.device_id = device.FullId();
    summary.first_utc = std::min({summary.first_utc, f.depth_timing.host_utc, f.color_timing.host_utc});
    summary.last_utc = std::max({summary.last_utc, f.depth_timing.host_utc, f.color_timing.host_utc});
    const Nanoseconds gap = std::chrono::abs(f.depth_timing.host_utc - f.color_timing.host_utc);
    summary.largest_pair_gap_s = std::max(summary.largest_pair_gap_s, std::chrono::duration<double>(gap).count());
    return true;
  };
  place(batch.front());
  if (!batch.front().registered_to_color) {
    summary.notes.push_back(
        "the recording does not say that depth is registered to colour: it is stored in the depth camera, and the sh "
        "pipeline registers it into the colour camera with the stored depth-to-colour transform (the identity unless "
        "the sensor reported one, which OpenNI2 recordings do not); if it was recorded with image registration on, "
        "import it again with --registered");
  }
  const auto flush = [&] {
    if (batch.empty()) return;
    writer->WriteRgbdFrames(batch);
    summary.pairs += static_cast<int>(batch.size());
    batch.clear();
  };
  int read = 1;
  while (options.frames == 0 || read < options.frames) {
    drivers::RgbdFrame frame;
    try {
      frame = sensor.WaitForFrame(options.frame_timeout);
    } catch (const drivers::DeviceError& e) {
      if (e.kind() != drivers::DeviceErrorKind::kTimeout) {
        flush();  // what was read is kept
        throw;
      }
      if (options.frames > 0) {
        summary.notes.push_back("the recording ended after " + std::to_string(read) + " of its " +
                                std::to_string(options.frames) + " frames");
      }
      break;
    }
    ++read;
    if (!place(frame)) {
      summary.notes.push_back("frame " + std::to_string(read) + " has no device time: left out");
      continue;
    }
    batch.push_back(std::move(frame));
    if (batch.size() >= static_cast<std::size_t>(options.frames_per_batch)) flush();
  }
  flush();
  for (const std::string& note : summary.notes) Note(*writer, device.FullId(), note);
  Note(*writer, device.FullId(), "imported " + std::to_string(summary.pairs) + " RGB-D frame pairs from " + what);
  summary.bytes = writer->bytes_written();
  return summary;
}

}  // namespace relume::capture
