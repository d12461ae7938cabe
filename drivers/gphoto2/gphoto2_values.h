// Pure helpers of the gphoto2 backend, kept apart from libgphoto2 calls so they can be tested
// on their own: reading the value strings cameras put in their configuration widgets, naming
// file formats, and mapping libgphoto2 result codes onto DeviceErrorKind.
//
// Conventions:
//  - Shutter speeds are seconds: "1/250", "0.3", "30", "30s", "2\"" (Canon and Nikon labels).
//    "bulb", "auto" and the like are not numbers (std::nullopt).
//  - Apertures are f-numbers: "f/5.6" or "5.6". ISO: "100", "Auto" is not a number.
//    EV compensation: "-1.3", "+0.7", "0".
//  - Matching a requested number to a choice: relative tolerance 1% (shutter, aperture, ISO:
//    neighbouring third stops differ by 26%), absolute 0.05 EV for EV compensation.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "drivers/device_error.h"

namespace relume::drivers::gphoto2 {

std::optional<double> ParseShutterSpeedS(const std::string& text);
std::optional<double> ParseApertureF(const std::string& text);
std::optional<double> ParseIso(const std::string& text);
std::optional<double> ParseEvCompensation(const std::string& text);

enum class ValueKind { kShutterSpeed, kAperture, kIso, kEvCompensation };
std::optional<double> ParseValue(ValueKind kind, const std::string& text);

// The index of the choice whose parsed value matches `value` (tolerances above), or -1.
int MatchChoice(ValueKind kind, const std::vector<std::string>& choices, double value);

// The parsed, sorted (ascending), de-duplicated numeric values among `choices`.
std::vector<double> NumericChoices(ValueKind kind, const std::vector<std::string>& choices);

// "jpeg", "tiff", "png", "nef", "cr2", ... from the file name's extension, else from the MIME
// type; "" when neither says.
std::string FileFormat(const std::string& file_name, const std::string& mime_type);

// How a libgphoto2 result code (< 0) maps onto a DeviceErrorKind. `opening` is true while a
// camera is being opened, where "device not found" means kNotFound rather than kDisconnected.
DeviceErrorKind KindFromGphotoResult(int result, bool opening);

// The hint appended to a kAccessDenied message: another process (usually GVFS) holds the camera.
const char* ClaimedByAnotherProcessHint();

}  // namespace relume::drivers::gphoto2
