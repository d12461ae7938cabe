// Frames as devices deliver them, with the metadata needed to reprocess them without the rig.
// The capture layer adds what only it knows (site, sun position, bracket id) when it stores
// them.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/pinhole.h"
#include "core/time.h"

namespace relume::drivers {

// Exposure as it was when the frame was taken. NaN where the device does not say.
struct ExposureRecord {
  double exposure_time_s = NAN;  // NaN on EV-only cameras that do not report it
  double ev_compensation = 0.0;  // relative EV asked of an EV-only camera, else 0
  double aperture_f = NAN;       // f-number
  double iso = NAN;
  double gain_db = NAN;
};

struct FrameTiming {
  UtcTime host_utc;                             // host clock when the frame was received
  MonotonicTime host_monotonic;                 // host steady clock, same instant
  std::optional<Nanoseconds> device_timestamp;  // the device's own clock, when it has one
  std::uint64_t sequence = 0;                   // frame counter of the device (or of the driver)
};

struct StillFrame {
  std::string device_id;  // DeviceInfo::FullId()
  std::string model;
  CameraImage image;  // decoded pixels
  // The camera's own file, byte for byte (raw or JPEG from a DSLR), when there is one; the
  // capture layer stores it unchanged. original_format: "jpeg", "nef", "cr2", "tiff", ...
  std::vector<std::uint8_t> original_file;
  std::string original_format;
  // Why `image` is empty although original_file is not (a camera file relume cannot decode,
  // e.g. a raw sensor layout LibRaw or relume does not handle); empty otherwise. The file is
  // still stored; only metering and processing need the pixels.
  std::string undecoded_reason;
  ExposureRecord exposure;
  FrameTiming timing;
  std::optional<double> sensor_temperature_c;
};

// A frame's file as a recorder wrote it, byte for byte: what a session played back or a recording
// imported delivers beside the decoded pixels, so that storing the frame again keeps the file.
struct RecordedFile {
  std::vector<std::uint8_t> bytes;  // empty: there is none (a live sensor)
  std::string format;               // the file's format: "png", "tiff", "exr", "jpeg"
  // Depth files: the stored units per metre (1000: 16-bit millimetres; 1: float metres; 5000:
  // the TUM RGB-D layout's PNGs). 0 for colour files.
  double depth_samples_per_metre = 0.0;
};

struct RgbdFrame {
  std::string device_id;
  cv::Mat depth_m;  // CV_32FC1, metres along the optical axis; NaN = no measurement (hole)
  CameraImage color;
  PinholeIntrinsics depth_intrinsics;
  PinholeIntrinsics color_intrinsics;
  // True when depth_m was resampled into the colour camera's image (then depth_intrinsics
  // equals color_intrinsics and color_from_depth is the identity).
  bool registered_to_color = false;
  Eigen::Isometry3d color_from_depth = Eigen::Isometry3d::Identity();
  FrameTiming depth_timing;
  FrameTiming color_timing;
  // The colour image's exposure where the device reports it (NaN fields otherwise): auto
  // exposure changes it from frame to frame, so radiance is comparable across frames only
  // through it.
  ExposureRecord color_exposure;
  // The files depth_m and color were decoded from, when the frame comes from a recording
  // (playback, import) rather than a live sensor. The capture layer stores the colour file as it
  // is, and the depth file when it is in the format and units the session stores depth in
  // (SessionWriter::WriteRgbdFrames); otherwise it encodes the pixels.
  RecordedFile depth_file;
  RecordedFile color_file;
};

}  // namespace relume::drivers
