#include "drivers/gphoto2/gphoto2_values.h"

#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

namespace relume::drivers::gphoto2 {
namespace {

std::string Trim(const std::string& text) {
  std::size_t begin = 0;
  std::size_t end = text.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  return text.substr(begin, end - begin);
}

// A plain decimal number covering the whole text.
std::optional<double> ParseDecimal(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

}  // namespace

std::optional<double> ParseShutterSpeedS(const std::string& raw) {
  std::string text = Trim(raw);
  while (!text.empty() && (text.back() == 's' || text.back() == '"')) text.pop_back();
  const std::size_t slash = text.find('/');
  std::optional<double> value;
  if (slash != std::string::npos) {
    const std::optional<double> num = ParseDecimal(text.substr(0, slash));
    const std::optional<double> den = ParseDecimal(text.substr(slash + 1));
    if (num && den && *den > 0.0) value = *num / *den;
  } else {
    value = ParseDecimal(text);
  }
  if (!value || *value <= 0.0) return std::nullopt;
  return value;
}

std::optional<double> ParseApertureF(const std::string& raw) {
  std::string text = Lower(Trim(raw));
  if (text.rfind("f/", 0) == 0) text = text.substr(2);
  const std::optional<double> value = ParseDecimal(text);
  if (!value || *value <= 0.0) return std::nullopt;
  return value;
}

std::optional<double> ParseIso(const std::string& raw) {
  std::string text = Lower(Trim(raw));
  if (text.rfind("iso", 0) == 0) text = Trim(text.substr(3));
  const std::optional<double> value = ParseDecimal(text);
  if (!value || *value <= 0.0) return std::nullopt;
  return value;
}

std::optional<double> ParseEvCompensation(const std::string& raw) {
  std::string text = Trim(raw);
  if (!text.empty() && text.front() == '+') text = text.substr(1);
  return ParseDecimal(text);
}

std::optional<double> ParseValue(ValueKind kind, const std::string& text) {
  switch (kind) {
    case ValueKind::kShutterSpeed: return ParseShutterSpeedS(text);
    case ValueKind::kAperture: return ParseApertureF(text);
    case ValueKind::kIso: return ParseIso(text);
    case ValueKind::kEvCompensation: return ParseEvCompensation(text);
  }
  return std::nullopt;
}

int MatchChoice(ValueKind kind, const std::vector<std::string>& choices, double value) {
  int best = -1;
  double best_error = INFINITY;
  for (std::size_t i = 0; i < choices.size(); ++i) {
    const std::optional<double> parsed = ParseValue(kind, choices[i]);
    if (!parsed) continue;
    const double error =
        kind == ValueKind::kEvCompensation ? std::abs(*parsed - value) : std::abs(*parsed - value) / std::abs(*parsed);
    const double tolerance = kind == ValueKind::kEvCompensation ? 0.05 : 0.01;
    if (error <= tolerance && error < best_error) {
      best = static_cast<int>(i);
      best_error = error;
    }
  }
  return best;
}

std::vector<double> NumericChoices(ValueKind kind, const std::vector<std::string>& choices) {
  std::vector<double> values;
  for (const std::string& choice : choices) {
    if (const std::optional<double> parsed = ParseValue(kind, choice)) values.push_back(*parsed);
  }
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  return values;
}

std::string FileFormat(const std::string& file_name, const std::string& mime_type) {
  const std::size_t dot = file_name.rfind('.');
  if (dot != std::string::npos && dot + 1 < file_name.size()) {
    std::string ext = Lower(file_name.substr(dot + 1));
    if (ext == "jpg" || ext == "jpeg") return "jpeg";
    if (ext == "tif") return "tiff";
    return ext;
  }
  const std::string mime = Lower(mime_type);
  if (mime == "image/jpeg") return "jpeg";
  if (mime == "image/tiff") return "tiff";
  if (mime == "image/png") return "png";
  if (mime == "image/x-nikon-nef") return "nef";
  if (mime == "image/x-canon-cr2") return "cr2";
  if (mime == "image/x-canon-cr3") return "cr3";
  if (mime == "image/x-sony-arw") return "arw";
  if (mime == "image/x-adobe-dng") return "dng";
  return "";
}

DeviceErrorKind KindFromGphotoResult(int result, bool opening) {
  switch (result) {
    case GP_ERROR_CAMERA_BUSY: return DeviceErrorKind::kBusy;
    case GP_ERROR_TIMEOUT: return DeviceErrorKind::kTimeout;
    case GP_ERROR_IO_USB_CLAIM:
    case GP_ERROR_IO_LOCK: return DeviceErrorKind::kAccessDenied;
    case GP_ERROR_IO_USB_FIND: return opening ? DeviceErrorKind::kNotFound : DeviceErrorKind::kDisconnected;
    case GP_ERROR_MODEL_NOT_FOUND:
    case GP_ERROR_UNKNOWN_PORT:
    case GP_ERROR_FILE_NOT_FOUND:
    case GP_ERROR_DIRECTORY_NOT_FOUND: return DeviceErrorKind::kNotFound;
    case GP_ERROR_CORRUPTED_DATA: return DeviceErrorKind::kCorruptFrame;
    case GP_ERROR_NOT_SUPPORTED:
    case GP_ERROR_BAD_PARAMETERS: return DeviceErrorKind::kUnsupportedSetting;
    default: return DeviceErrorKind::kIo;  // GP_ERROR_IO*, GP_ERROR, camera and OS failures
  }
}

const char* ClaimedByAnotherProcessHint() {
  return "another process holds the camera (usually the desktop's GVFS gphoto2 volume monitor, which claims "
         "cameras when they are plugged in): unmount it with `gio mount -s gphoto2`, or stop it with "
         "`systemctl --user stop gvfs-gphoto2-volume-monitor` (or kill gvfs-gphoto2-volume-monitor), then retry";
}

}  // namespace relume::drivers::gphoto2
