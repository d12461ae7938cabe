// `relume session import`: a session made from still images recorded elsewhere (a folder of raw
// or JPEG/TIFF files from a gphoto2 script, a camera's card), so that they go through
// calibration and processing like a captured session.
//
// What an imported session holds, and how it differs from a captured one:
//  - Every file byte for byte with its SHA-256 (SessionWriter's durability rule); raw files are
//    decoded through LibRaw, JPEG/TIFF through OpenCV; the sun per frame for the session's site.
//  - Time, exposure time, aperture and ISO from each file's EXIF (Exiv2): DateTimeOriginal with
//    SubSecTimeOriginal, in the time zone OffsetTimeOriginal gives or, when the file has none,
//    the one the user states (`utc_offset`; there is no default: a camera's clock is local time
//    of an unknown zone). A value a file lacks comes from the options' fallback, else the file
//    is refused with the flag that supplies it.
//  - Frames' UTC is the EXIF time (to the sub-second the file gives); the monotonic time is the
//    same instant relative to the first frame, and the device time is the EXIF time itself.
//  - Brackets: consecutive frames of one camera (in time order) within `bracket_gap_s` of the
//    previous one, each with a different exposure, form a bracket; a frame repeating an exposure
//    of the current bracket starts a new one. Single frames are brackets of one.
//  - The device: backend "import", id from the camera's EXIF make and model (`camera_id`
//    replaces it). Files of several cameras in one import are refused (import them apart).
//  - No rig and no scene model: `relume session add-scene-model --from` adds cameras, geometry
//    and lamps (docs/real-data.md).
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/site.h"
#include "core/time.h"

namespace relume::capture {

struct ImportOptions {
  std::vector<std::filesystem::path> inputs;  // files, or folders (their image files, not recursive)
  Site site;
  std::string name;                                // the session's name (default: the output folder's)
  std::optional<std::chrono::seconds> utc_offset;  // of EXIF times without OffsetTimeOriginal
  double bracket_gap_s = 3.0;
  std::string camera_id;  // device id (default: from EXIF make and model)
  // Used for files whose EXIF lacks them (NaN: none; such a file is then refused).
  double exposure_time_s = NAN;
  double aperture_f = NAN;
  double iso = NAN;
  // The JPEG/TIFF/PNG files hold values proportional to radiance (16-bit linear TIFFs from a raw
  // converter, e.g. `dcraw -4 -T`): stored as sensor-linear, so processing needs no camera
  // response. Raw files are sensor-linear anyway.
  bool linear = false;

  bool IsValid(std::string* why) const;
};

struct ImportSummary {
  std::filesystem::path session;
  std::string device_id;
  int frames = 0;
  int brackets = 0;
  UtcTime first_utc{};
  UtcTime last_utc{};
  std::uint64_t bytes = 0;
  std::vector<std::string> notes;  // per file: values taken from the fallbacks, undecodable raws

  std::string Report() const;  // several lines for the CLI
};

// The image files an import takes (by extension: .jpg .jpeg .tif .tiff .png and the raw
// formats core/raw_file.h lists), sorted by name. IoError for an input that does not exist,
// InvalidArgumentError when nothing is found.
std::vector<std::filesystem::path> ImportableFiles(const std::vector<std::filesystem::path>& inputs);

// Reads every file's metadata first (so a bad file leaves no session behind), then creates the
// session in `out` (new or empty) and stores the frames in time order. Throws
// InvalidArgumentError naming the file and the flag for missing metadata, IoError for
// unreadable files or storage failures (frames stored by then stay acknowledged).
ImportSummary ImportStills(const ImportOptions& options, const std::filesystem::path& out);

}  // namespace relume::capture
