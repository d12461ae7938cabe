// The shared first stage of every pipeline: a still camera's frames as linear radiance.
//
// A bracket (or a single frame) of a session becomes one linear float RGB image:
//  - sensor-linear frames (raw) through their black and white level; Bayer mosaics demosaiced;
//  - camera-encoded frames (JPEG, 8-bit) through the inverse response the session recorded for
//    the device (calibration kind "response" or "profile"), or, when it has none, a response
//    recovered from the bracket itself (Debevec-Malik; EV-only cameras with Loscos et al.'s
//    per-image scale), logged as a decision;
//  - merged with calibration::MergeHdr when the bracket has several frames; a single frame is
//    linearised without a merge (the planner logs "skip merge");
//  - the device's colour profile (gain + 3x3 matrix, calibration kind "profile") applied when
//    the session has one.
// Units: relative radiance, X / (t * ISO/100) where the exposure time and ISO are known
// (EV-only cameras: 2^EV), the same scale for every bracket of one device, so ratios between
// brackets are meaningful. Cached as stage "radiance" keyed by the frames' SHA-256 and the
// settings; the EXR is <stage dir>/radiance.exr.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "calibration/calibration_profile.h"
#include "calibration/hdr_merge.h"
#include "calibration/response.h"
#include "core/image.h"
#include "core/time.h"
#include "pipeline/pipeline.h"

namespace relume::pipeline {

// The knobs of linear radiance (knobs.h), shared by every pipeline that linearises brackets.
struct RadianceKnobs {
  calibration::HdrMergeOptions merge;
  calibration::ResponseOptions response;
  std::string response_smoothness = calibration::ToString(calibration::ResponseOptions{}.smoothness);

  template <typename V>
  void VisitKnobs(V& v) {
    v.Knob("merge_black_margin", merge.black_margin, "code values above black below which a pixel is not trusted",
           {"radiance"});
    v.Knob("merge_saturation_margin", merge.saturation_margin,
           "code values below white above which a pixel is not trusted", {"radiance"});
    v.Knob("response_samples", response.sample_count, "pixels sampled to recover a response from a bracket",
           {"radiance"});
    v.Knob("response_lambda", response.lambda, "smoothness weight of the recovered response", {"radiance"});
    v.Knob("response_smoothness", response_smoothness, "smoothness prior of the recovered response", {"radiance"});
  }
};

// `knobs` followed by the RadianceKnobs, for a pipeline that linearises brackets.
std::vector<KnobInfo> WithRadianceKnobs(std::vector<KnobInfo> knobs);

struct BracketRadiance {
  std::string device_id;
  std::optional<std::int64_t> bracket_id;  // none for a frame outside a bracket
  std::vector<std::int64_t> frame_ids;
  UtcTime utc;  // of the bracket's first frame
  double sun_azimuth_deg = 0.0;
  double sun_elevation_deg = 0.0;
  RadianceImage radiance;  // CV_32FC3, relative units (see above)
  cv::Mat status;          // CV_8UC1 calibration::HdrPixelStatus (0 = every channel well exposed)
  std::filesystem::path exr;
  StageKey key;  // what the radiance depends on; dependants AddKey() it
};

// Still-camera frames grouped by bracket (frames outside a bracket stand alone), in capture
// order, optionally restricted to the frames a selector picks (see SelectFrames).
std::vector<std::vector<capture::FrameRecord>> StillBrackets(const capture::SessionReader& session,
                                                             const std::optional<std::string>& selector);

// The linearisation itself, without caching or decisions (`relume calibrate --session` uses
// it to measure a chart). `profile`: gain + CCM to apply (none for a chart being fitted);
// `response`: the inverse response for camera-encoded frames (none: recovered from the
// bracket, which then needs two frames or more).
struct LinearisedBracket {
  RadianceImage radiance;
  cv::Mat status;
  // "sensor-linear", "recorded", "recovered from the bracket" (+ ", low confidence (why)")
  std::string response_source;
};
LinearisedBracket LineariseBracket(const capture::SessionReader& session,
                                   const std::vector<capture::FrameRecord>& bracket,
                                   const std::optional<calibration::CameraResponse>& response,
                                   const std::optional<calibration::CalibrationProfile>& profile,
                                   const calibration::HdrMergeOptions& merge,
                                   const calibration::ResponseOptions& response_options);

// The newest calibration of a device of the given kind ("response" or "profile") stored in the
// session, with its id; nullopt when there is none.
std::optional<std::pair<calibration::CalibrationProfile, std::int64_t>> SessionCalibration(
    const capture::SessionReader& session, const std::string& device_id, const std::string& kind);

// The calibrations LinearRadiance uses for a device's frames: its newest profile (gain + CCM,
// applied to the radiance), and the inverse response for camera-encoded frames (the profile's
// when it holds one, else the newest "response" calibration's); the calibration ids (0: none)
// key the radiance stage. LineariseBracket(session, bracket, c.response, c.profile, ...) is then
// what the radiance stage computes.
struct DeviceCalibrations {
  std::optional<calibration::CalibrationProfile> profile;
  std::optional<calibration::CameraResponse> response;
  std::int64_t profile_id = 0;
  std::int64_t response_id = 0;
};
DeviceCalibrations RecordedCalibrations(const capture::SessionReader& session, const std::string& device_id);

// Settings read (all optional): merge_black_margin, merge_saturation_margin (codes),
// response_samples, response_lambda, response_smoothness (code or log-code). Throws InvalidArgumentError when the
// frames cannot be linearised (an encoded single frame and no recorded response: the message says to run `relume
// calibrate`). `load` false: the stage runs (or is reused) but its images are not read back
// (`radiance` and `status` stay empty; `exr` names the radiance), for callers that read them
// lazily.
BracketRadiance LinearRadiance(PipelineRun& run, const std::vector<capture::FrameRecord>& bracket, bool load = true);

// An 8-bit sRGB preview of linear radiance: scaled so that `white` maps to 1, clipped, sRGB
// transfer. With white <= 0 the 99th percentile of the finite luminance is used.
cv::Mat RadiancePreview(const RadianceImage& radiance, double white = 0.0);

}  // namespace relume::pipeline
