#include "capture/import.h"

// Exiv2 0.27's API hands images out as std::auto_ptr (deprecated in C++17).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>
#pragma GCC diagnostic pop

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "capture/session.h"
#include "core/error.h"
#include "core/input_file.h"
#include "core/raw_file.h"

namespace relume::capture {

namespace fs = std::filesystem;

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool Importable(const fs::path& path) {
  const std::string format = FileFormatOf(path);
  return format == "jpeg" || format == "tiff" || format == "png" || IsRawFormat(format);
}

// One file's EXIF, as the import needs it.
struct FileMetadata {
  fs::path path;
  std::vector<std::uint8_t> bytes;
  std::string make, model;
  UtcTime utc{};
  double exposure_time_s = NAN;
  double aperture_f = NAN;
  double iso = NAN;
  std::vector<std::string> notes;
};

std::optional<std::string> ExifString(const Exiv2::ExifData& exif, const char* key) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  if (it == exif.end() || it->count() == 0) return std::nullopt;
  std::string value = it->toString();
  while (!value.empty() && (value.back() == ' ' || value.back() == '\0')) value.pop_back();
  if (value.empty()) return std::nullopt;
  return value;
}

double ExifNumber(const Exiv2::ExifData& exif, const char* key) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  if (it == exif.end() || it->count() == 0) return NAN;
  const Exiv2::Rational r = it->toRational(0);
  if (r.second != 0 && it->typeId() != Exiv2::unsignedShort && it->typeId() != Exiv2::unsignedLong) {
    return static_cast<double>(r.first) / r.second;
  }
  return static_cast<double>(it->toLong(0));
}

// "2026:06:21 09:00:00" (EXIF) -> the local civil time as if it were UTC; "+03:00" -> offset.
std::optional<UtcTime> ParseExifTime(const std::string& text) {
  int y, mo, d, h, mi, s;
  if (std::sscanf(text.c_str(), "%d:%d:%d %d:%d:%d", &y, &mo, &d, &h, &mi, &s) != 6) return std::nullopt;
  char iso[32];
  std::snprintf(iso, sizeof(iso), "%04d-%02d-%02dT%02d:%02d:%02dZ", y, mo, d, h, mi, s);
  try {
    return ParseIso8601(iso).utc;
  } catch (const InvalidArgumentError&) {
    return std::nullopt;
  }
}

std::optional<std::chrono::seconds> ParseOffset(const std::string& text) {
  try {
    return ParseIso8601("2000-01-01T00:00:00" + text).utc_offset;
  } catch (const InvalidArgumentError&) {
    return std::nullopt;
  }
}

FileMetadata ReadMetadata(const fs::path& path, const ImportOptions& options) {
  FileMetadata m;
  m.path = path;
  m.bytes = ReadInputBytes(path);
  Exiv2::ExifData exif;
  try {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
    auto image = Exiv2::ImageFactory::open(m.bytes.data(), static_cast<long>(m.bytes.size()));
#pragma GCC diagnostic pop
    image->readMetadata();
    exif = image->exifData();
  } catch (const Exiv2::AnyError& e) {
    throw InvalidArgumentError(path.string() + ": cannot read its metadata (" + e.what() +
                               "); is it an image file? relume imports raw, JPEG, TIFF and PNG stills");
  }
  m.make = ExifString(exif, "Exif.Image.Make").value_or("");
  m.model = ExifString(exif, "Exif.Image.Model").value_or("");
  const std::optional<std::string> when = ExifString(exif, "Exif.Photo.DateTimeOriginal");
  const std::optional<UtcTime> local = when ? ParseExifTime(*when) : std::nullopt;
  if (!local) {
    throw InvalidArgumentError(path.string() + ": its EXIF has no DateTimeOriginal" +
                               (when ? " that reads as 'YYYY:MM:DD HH:MM:SS' ('" + *when + "')" : std::string()) +
                               "; relume needs each frame's time for the sun's position, and cannot import it");
  }
  std::optional<std::chrono::seconds> offset;
  if (const auto text = ExifString(exif, "Exif.Photo.OffsetTimeOriginal")) offset = ParseOffset(*text);
  if (!offset) offset = options.utc_offset;
  if (!offset) {
    throw InvalidArgumentError(path.string() + ": its EXIF time " + *when +
                               " has no time zone (no OffsetTimeOriginal); give the camera clock's offset from UTC "
                               "with --tz (e.g. --tz +03:00)");
  }
  m.utc = *local - *offset;
  if (const auto sub = ExifString(exif, "Exif.Photo.SubSecTimeOriginal")) {
    if (std::all_of(sub->begin(), sub->end(), [](unsigned char c) { return std::isdigit(c); })) {
      m.utc += std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(std::stod("0." + *sub)));
    }
  }
  m.exposure_time_s = ExifNumber(exif, "Exif.Photo.ExposureTime");
  m.aperture_f = ExifNumber(exif, "Exif.Photo.FNumber");
  m.iso = ExifNumber(exif, "Exif.Photo.ISOSpeedRatings");
  const auto fill = [&](double* value, double fallback, const char* what, const char* flag) {
    if (std::isfinite(*value) && *value > 0.0) return;
    if (!(std::isfinite(fallback) && fallback > 0.0)) {
      throw InvalidArgumentError(path.string() + ": its EXIF has no " + what + "; give it with " + flag +
                                 " (it applies to every file that lacks it)");
    }
    *value = fallback;
    m.notes.push_back(path.filename().string() + ": " + what + " from " + flag);
  };
  fill(&m.exposure_time_s, options.exposure_time_s, "exposure time", "--exposure-time");
  fill(&m.aperture_f, options.aperture_f, "aperture (FNumber)", "--aperture");
  fill(&m.iso, options.iso, "ISO", "--iso");
  return m;
}

// Decoded pixels of a stored still, as the gphoto2 driver decodes a camera's file.
void Decode(const FileMetadata& m, const std::string& format, bool linear, drivers::StillFrame* frame) {
  if (IsRawFormat(format)) {
    try {
      frame->image = DecodeRawFile(m.bytes, m.path.string()).image;
    } catch (const Error& e) {
      frame->undecoded_reason = e.what();  // stored byte for byte all the same
    }
    return;
  }
  const cv::Mat decoded = cv::imdecode(m.bytes, cv::IMREAD_UNCHANGED);
  if (decoded.empty() || (decoded.depth() != CV_8U && decoded.depth() != CV_16U)) {
    throw InvalidArgumentError(m.path.string() + ": cannot decode it as " + format + " with 8- or 16-bit samples");
  }
  CameraImage& image = frame->image;
  if (decoded.channels() == 1) {
    image.pixels = decoded;
    image.layout = ColorLayout::kMono;
  } else {
    cv::cvtColor(decoded, image.pixels, decoded.channels() == 4 ? cv::COLOR_BGRA2RGB : cv::COLOR_BGR2RGB);
    image.layout = ColorLayout::kRgb;
  }
  const bool sixteen = decoded.depth() == CV_16U;
  image.encoding = linear ? SampleEncoding::kSensorLinear : SampleEncoding::kCameraResponse;
  image.bits_per_sample = sixteen ? 16 : 8;
  image.black_level = 0;
  image.white_level = sixteen ? 65535 : 255;
}

std::string DeviceIdFrom(const std::string& make, const std::string& model) {
  std::string id;
  for (char c : Lower(make.empty() && model.empty() ? "camera" : (make + "-" + model))) {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) != 0;
    if (keep) {
      id += c;
    } else if (!id.empty() && id.back() != '-') {
      id += '-';
    }
  }
  while (!id.empty() && id.back() == '-') id.pop_back();
  return id;
}

bool SameExposure(const FileMetadata& a, const FileMetadata& b) {
  const auto close = [](double x, double y) { return std::abs(x - y) <= 1e-3 * std::max(std::abs(x), std::abs(y)); };
  return close(a.exposure_time_s, b.exposure_time_s) && close(a.aperture_f, b.aperture_f) && close(a.iso, b.iso);
}

}  // namespace

bool ImportOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (inputs.empty()) return fail("no input files or folders");
  std::string reason;
  if (!site.IsValid(&reason)) return fail("site: " + reason);
  if (!(bracket_gap_s >= 0.0 && bracket_gap_s <= 3600.0)) return fail("--bracket-gap must be within [0, 3600] s");
  if (utc_offset && std::chrono::abs(*utc_offset) > std::chrono::hours(14)) {
    return fail("--tz must be within -14:00 .. +14:00");
  }
  for (const auto& [value, flag] :
       {std::pair{exposure_time_s, "--exposure-time"}, {aperture_f, "--aperture"}, {iso, "--iso"}}) {
    if (!std::isnan(value) && !(std::isfinite(value) && value > 0.0)) {
      return fail(std::string(flag) + " must be a positive number");
    }
  }
  return true;
}

std::string ImportSummary::Report() const {
  std::ostringstream out;
  out << "imported " << frames << " frames of " << device_id << " in " << brackets << " brackets, "
      << FormatIso8601(first_utc) << " .. " << FormatIso8601(last_utc) << ", " << bytes / 1024 << " KiB -> "
      << session.string() << "\n";
  for (const std::string& note : notes) out << "  note: " << note << "\n";
  return out.str();
}

std::vector<fs::path> ImportableFiles(const std::vector<fs::path>& inputs) {
  std::vector<fs::path> files;
  for (const fs::path& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      for (const fs::directory_entry& entry : fs::directory_iterator(input)) {
        if (entry.is_regular_file() && Importable(entry.path())) files.push_back(entry.path());
      }
    } else if (fs::exists(input, ec)) {
      if (!Importable(input)) {
        throw InvalidArgumentError(input.string() +
                                   ": not an image relume imports (raw, .jpg/.jpeg, .tif/.tiff, .png)");
      }
      files.push_back(input);
    } else {
      throw IoError(input.string(), "does not exist");
    }
  }
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  if (files.empty()) throw InvalidArgumentError("no image files (raw, JPEG, TIFF, PNG) in the inputs given");
  return files;
}

ImportSummary ImportStills(const ImportOptions& options, const fs::path& out) {
  ThrowIfInvalid(options, "import options");
  // Every file's metadata first: a file that cannot be imported leaves no session behind.
  std::vector<FileMetadata> files;
  for (const fs::path& path : ImportableFiles(options.inputs)) files.push_back(ReadMetadata(path, options));
  const std::string camera = files.front().make + " " + files.front().model;
  for (const FileMetadata& m : files) {
    if (m.make != files.front().make || m.model != files.front().model) {
      throw InvalidArgumentError(m.path.string() + " is from camera '" + m.make + " " + m.model + "', " +
                                 files.front().path.string() + " from '" + camera +
                                 "'; import each camera's files into a session of its own");
    }
  }
  std::stable_sort(files.begin(), files.end(),
                   [](const FileMetadata& a, const FileMetadata& b) { return a.utc < b.utc; });

  ImportSummary summary;
  summary.session = out;
  drivers::DeviceInfo device;
  device.backend = "import";
  device.id = options.camera_id.empty() ? DeviceIdFrom(files.front().make, files.front().model) : options.camera_id;
  device.kind = drivers::DeviceKind::kStillCamera;
  device.model = camera == " " ? "unknown camera" : camera;
  device.address = "files";
  summary.device_id = device.FullId();

  SessionInfo info;
  info.name = options.name.empty() ? out.filename().string() : options.name;
  info.site = options.site;
  info.software_version = "relume import";
  info.clock_name = "EXIF DateTimeOriginal of the imported files";
  info.created_utc = UtcNow();
  std::unique_ptr<SessionWriter> writer = SessionWriter::Create(out, info);
  writer->AddDevice(device);

  // Brackets: runs of frames close in time with distinct exposures.
  std::size_t begin = 0;
  while (begin < files.size()) {
    std::size_t end = begin + 1;
    while (end < files.size()) {
      const double gap = std::chrono::duration<double>(files[end].utc - files[end - 1].utc).count();
      const bool repeats = std::any_of(files.begin() + static_cast<std::ptrdiff_t>(begin),
                                       files.begin() + static_cast<std::ptrdiff_t>(end),
                                       [&](const FileMetadata& m) { return SameExposure(m, files[end]); });
      if (gap > options.bracket_gap_s || repeats) break;
      ++end;
    }
    const std::int64_t bracket = writer->BeginBracket(device.FullId(), files[begin].utc, static_cast<int>(end - begin));
    for (std::size_t i = begin; i < end; ++i) {
      const FileMetadata& m = files[i];
      drivers::StillFrame frame;
      frame.device_id = device.FullId();
      frame.model = device.model;
      frame.original_file = m.bytes;
      frame.original_format = FileFormatOf(m.path);
      Decode(m, frame.original_format, options.linear, &frame);
      if (!frame.undecoded_reason.empty())
        summary.notes.push_back(m.path.filename().string() + ": " + frame.undecoded_reason);
      frame.exposure.exposure_time_s = m.exposure_time_s;
      frame.exposure.aperture_f = m.aperture_f;
      frame.exposure.iso = m.iso;
      frame.timing.host_utc = m.utc;
      frame.timing.host_monotonic = MonotonicTime(m.utc - files.front().utc);
      frame.timing.device_timestamp = m.utc.time_since_epoch();
      frame.timing.sequence = i;
      writer->WriteStillFrame(frame, bracket, static_cast<int>(i - begin));
      summary.bytes += m.bytes.size();
      for (const std::string& note : m.notes) summary.notes.push_back(note);
      ++summary.frames;
    }
    writer->EndBracket(bracket, "complete", "imported");
    ++summary.brackets;
    begin = end;
  }
  writer->AddEvent(
      {0, UtcNow(), MonotonicNow(), device.FullId(), "note",
       "imported " + std::to_string(summary.frames) + " files in " + std::to_string(summary.brackets) + " brackets"});
  summary.first_utc = files.front().utc;
  summary.last_utc = files.back().utc;
  return summary;
}

}  // namespace relume::capture
