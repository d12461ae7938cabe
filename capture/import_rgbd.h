// `relume session import --rgbd DIR`: a session from an RGB-D recording made elsewhere, so that
// the SH pipeline (and anything else that reads RGB-D frames) processes it like a captured one.
//
// The recording is in the layout of the TUM RGB-D benchmark (Sturm et al., IROS 2012), which
// many recorders and converters write:
//   DIR/rgb.txt    lines "TIMESTAMP FILE": the colour frames (8- or 16-bit PNG or JPEG)
//   DIR/depth.txt  lines "TIMESTAMP FILE": the depth frames (16-bit single-channel PNG, the
//                  depth along the optical axis times `depth_units_per_metre`; 0 = no depth)
// TIMESTAMP is Unix time in seconds (UTC) with any number of decimals, FILE is relative to DIR;
// lines starting with '#' are comments.
//
// What an imported RGB-D session holds:
//  - Pairs: each depth frame with the colour frame nearest in time, at most `max_pair_gap_s`
//    apart, each colour frame used once (as the benchmark's associate.py pairs them). Frames
//    left without a partner are not imported; the summary counts them.
//  - Files byte for byte with their SHA-256: every colour file, and depth files in millimetres
//    (`depth_units_per_metre` 1000, what OpenNI, librealsense and the Azure Kinect tools write).
//    Depth in other units (the benchmark's own 5000 per metre) is stored as 32-bit float metres
//    (OpenEXR, exact for 16-bit values); the summary lists the originals' SHA-256.
//  - Depth must be registered to colour (the same camera and image size): the stored geometry
//    row (capture/rgbd_geometry.h) says so, with the colour intrinsics the user gives (no lens
//    distortion: the frames must be undistorted already).
//  - The device: backend "import", kind RGB-D sensor, id `camera_id`. Frame times are the
//    files' timestamps (UTC, and the device time); the monotonic time counts from the first.
//    The sun per frame, for the session's site.
//  - Every list line is read, and every listed file checked (format, exists), before the session
//    is created; each file is then read and decoded once, as it is stored. A frame refused then
//    (a file that does not decode, a size that differs) removes what the import made: the
//    folder if it made it, else the session's database and frames folder. The recording's files
//    stay where they are, so a refused import loses nothing, leaves nothing behind, and the same
//    --out works again. (Until 2026-12-07 every file was read and decoded twice, once to check
//    it before the session existed. 200 pairs of 640x480 PNG (colour and 16-bit depth), 2 cores:
//    5.44 -> 3.05 s, the stored frames identical byte for byte; measured by hand with
//    /usr/bin/time, median of 3, on a generated recording: no benchmark repeats it.)
//
// `relume session import --oni FILE --start UTC` (ImportRgbdStream): a recording another library
// plays back as an RGB-D sensor (an OpenNI2 .oni file through drivers/openni2): every frame it
// returns, with the geometry it reports, stored as a captured stream's frames (encoded: the
// recording is one file, whose SHA-256 the session's events keep). A recording holds only its
// device's clock, so the user states the first frame's UTC; each frame's UTC is that plus its
// device time since the first frame.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/pinhole.h"
#include "core/site.h"
#include "core/time.h"
#include "drivers/rgbd_sensor.h"

namespace relume::capture {

struct RgbdImportOptions {
  std::filesystem::path folder;  // holds rgb.txt and depth.txt
  Site site;
  std::string name;  // the session's name (default: the output folder's)
  std::string camera_id = "rgbd";
  // The colour camera (depth is registered to it): fx, fy, cx, cy in pixels (core/pinhole.h's
  // convention, pixel centres at +0.5). Width and height: 0 takes the first colour frame's,
  // else they must match it.
  PinholeIntrinsics color_intrinsics;
  double depth_units_per_metre = 1000.0;  // a 16-bit depth value of v is v / this metres
  double max_pair_gap_s = 0.02;
  // The colour frames' exposure when the recording states one (NaN: unknown; processing then
  // takes the frames as equally exposed).
  double exposure_time_s = NAN;
  double iso = NAN;
  int frames_per_batch = 16;  // pairs committed together (SessionWriter::WriteRgbdFrames)

  bool IsValid(std::string* why) const;
};

struct RgbdImportSummary {
  std::filesystem::path session;
  std::string device_id;
  int pairs = 0;
  int unpaired_color = 0;  // colour frames no depth frame was paired with (not imported)
  int unpaired_depth = 0;  // depth frames without a colour frame within max_pair_gap_s
  double largest_pair_gap_s = 0.0;
  bool depth_converted = false;  // stored as float metres, not byte for byte
  UtcTime first_utc{};
  UtcTime last_utc{};
  std::uint64_t bytes = 0;
  // With depth_converted: "FILE SHA-256" of every original depth file, as the session's
  // events record them.
  std::vector<std::string> original_depth_sha256;
  std::vector<std::string> notes;  // e.g. a played recording that ended early

  std::string Report() const;  // several lines for the CLI
};

// One line of a TUM list: the timestamp (exact to the nanosecond) and the file.
struct RgbdListEntry {
  UtcTime utc{};
  std::filesystem::path file;  // relative to the list's folder
};
// Reads DIR/NAME. Throws IoError when it cannot be read and InvalidArgumentError naming the line
// for a malformed one (a timestamp that is not a number, a missing file name) or for a list
// without frames.
std::vector<RgbdListEntry> ReadRgbdList(const std::filesystem::path& folder, const std::string& name);

// Imports the recording into a new (or empty) session folder `out`. Throws
// InvalidArgumentError naming the file and what to do (a depth frame not the colour frame's
// size, an undecodable file, no pair within the gap), IoError for a missing file or a storage
// failure (frames stored by then stay acknowledged).
RgbdImportSummary ImportRgbd(const RgbdImportOptions& options, const std::filesystem::path& out);

struct RgbdStreamImportOptions {
  Site site;
  std::string name;  // the session's name (default: the output folder's)
  std::string camera_id = "rgbd";
  std::string model = "RGB-D recording";  // the device's model in the session
  // UTC of the recording's first frame (required: recordings carry no wall-clock time).
  std::optional<UtcTime> start_utc;
  // Frames the recording holds (OpenNI2's frame count), or 0: read until the sensor times out.
  int frames = 0;
  std::chrono::milliseconds frame_timeout{5000};
  // The user's word that depth was registered to colour when recorded, for recordings that do
  // not say (an OpenNI2 .oni plays back with registration off whatever it was): the frames are
  // then stored as registered (depth in the colour camera, its intrinsics).
  bool registered = false;
  std::string source;         // what was imported (a file), for the session's events
  std::string source_sha256;  // its SHA-256 when it is one file
  int frames_per_batch = 16;

  bool IsValid(std::string* why) const;
};

// Reads frames from `sensor` (started by the caller with the stream configuration to import)
// into a new session in `out`. The first frame is read before the session is created, so a
// recording that gives none leaves nothing behind. Throws InvalidArgumentError when frames
// carry no device time, DeviceError from the sensor, IoError for storage failures (frames stored
// by then stay acknowledged). A recording that ends before `frames` is kept and noted.
RgbdImportSummary ImportRgbdStream(drivers::RgbdSensor& sensor, const RgbdStreamImportOptions& options,
                                   const std::filesystem::path& out);

}  // namespace relume::capture
