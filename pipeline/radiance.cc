#include "pipeline/radiance.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/calibration_profile.h"
#include "calibration/demosaic.h"
#include "calibration/hdr_merge.h"
#include "calibration/image_file.h"
#include "calibration/response.h"
#include "calibration/undistort.h"
#include "core/color.h"
#include "core/error.h"

namespace relume::pipeline {
namespace fs = std::filesystem;

std::vector<std::vector<capture::FrameRecord>> StillBrackets(const capture::SessionReader& session,
                                                             const std::optional<std::string>& selector) {
  const std::vector<capture::FrameRecord> frames =
      selector ? SelectFrames(session, *selector) : SelectFrames(session, "all");
  std::vector<std::vector<capture::FrameRecord>> brackets;
  std::map<std::int64_t, std::size_t> index_of_bracket;
  for (const capture::FrameRecord& f : frames) {
    if (f.stream != "still") continue;
    if (!f.bracket_id) {
      brackets.push_back({f});
      continue;
    }
    const auto [it, inserted] = index_of_bracket.emplace(*f.bracket_id, brackets.size());
    if (inserted) brackets.emplace_back();
    brackets[it->second].push_back(f);
  }
  return brackets;
}

namespace {

// Relative exposure of a frame: t * ISO/100, or 2^EV for EV-only cameras.
double RelativeExposure(const drivers::ExposureRecord& e) {
  double t =
      std::isfinite(e.exposure_time_s) && e.exposure_time_s > 0.0 ? e.exposure_time_s : std::exp2(e.ev_compensation);
  if (std::isfinite(e.iso) && e.iso > 0.0) t *= e.iso / 100.0;
  return t;
}

bool IsEvOnly(const std::vector<capture::FrameRecord>& bracket) {
  return std::all_of(bracket.begin(), bracket.end(),
                     [](const capture::FrameRecord& f) { return !std::isfinite(f.exposure.exposure_time_s); });
}

// The relative exposures of a bracket's frames. Every frame needs its exposure: a time (finite,
// positive) or, in a bracket without times (EV-only cameras), a finite EV. A damaged row (time
// -1, NULL) would otherwise be merged at 2^EV = 1, a wrong scale with no word about it.
std::vector<double> RelativeExposures(const std::vector<capture::FrameRecord>& bracket, const std::string& name) {
  const bool ev_only = IsEvOnly(bracket);
  std::vector<double> times;
  for (const capture::FrameRecord& f : bracket) {
    const double t = f.exposure.exposure_time_s;
    const bool known = ev_only ? std::isfinite(f.exposure.ev_compensation) : std::isfinite(t) && t > 0.0;
    if (!known) {
      const std::string what = ev_only         ? "has no EV"
                               : std::isnan(t) ? "has no exposure time"
                                               : "has exposure time " + std::to_string(t) + " s";
      throw InvalidArgumentError(name + ": frame " + std::to_string(f.id) + " (" + f.file_path + ") " + what +
                                 "; a merge needs every frame's exposure (is the session damaged? `relume session "
                                 "verify` checks it)");
    }
    times.push_back(RelativeExposure(f.exposure));
  }
  return times;
}

CameraImage AsRgb(CameraImage image) {
  if (image.layout == ColorLayout::kRgb) return image;
  if (image.layout == ColorLayout::kMono) {
    cv::Mat rgb;
    cv::cvtColor(image.pixels, rgb, cv::COLOR_GRAY2RGB);
    image.pixels = rgb;
    image.layout = ColorLayout::kRgb;
    return image;
  }
  return calibration::DemosaicBilinear(image);
}

}  // namespace

std::optional<std::pair<calibration::CalibrationProfile, std::int64_t>> SessionCalibration(
    const capture::SessionReader& session, const std::string& device_id, const std::string& kind) {
  std::optional<std::pair<calibration::CalibrationProfile, std::int64_t>> found;
  for (const capture::CalibrationRecord& c : session.Calibrations()) {
    if (c.device_id != device_id || c.kind != kind) continue;
    found.emplace(calibration::ProfileFromJson(c.json, "session " + session.dir().string() + " calibration " +
                                                           std::to_string(c.id) + " (" + kind + ")"),
                  c.id);
  }
  return found;
}

LinearisedBracket LineariseBracket(const capture::SessionReader& session,
                                   const std::vector<capture::FrameRecord>& bracket,
                                   const std::optional<calibration::CameraResponse>& recorded,
                                   const std::optional<calibration::CalibrationProfile>& profile,
                                   const calibration::HdrMergeOptions& merge,
                                   const calibration::ResponseOptions& response_options) {
  RELUME_CHECK(!bracket.empty());
  const std::string name = bracket.front().bracket_id ? "bracket " + std::to_string(*bracket.front().bracket_id)
                                                      : "frame " + std::to_string(bracket.front().id);
  std::vector<double> times = RelativeExposures(bracket, name);
  std::vector<CameraImage> frames;
  for (const capture::FrameRecord& f : bracket) frames.push_back(AsRgb(session.LoadImage(f)));
  LinearisedBracket out;
  calibration::CameraResponse response;
  if (bracket.front().encoding == SampleEncoding::kSensorLinear) {
    response = calibration::SensorLinearResponse(frames.front());
    out.response_source = "sensor-linear";
  } else if (recorded) {
    response = *recorded;
    out.response_source = "recorded";
  } else {
    if (frames.size() < 2) {
      throw InvalidArgumentError(name + " is a single camera-encoded frame and no response is recorded for " +
                                 bracket.front().device_id + ": record one with `relume calibrate response --session " +
                                 session.dir().string() + " --frames bracket:N`");
    }
    calibration::ResponseSummary summary;
    if (IsEvOnly(bracket)) {
      std::vector<double> ev;
      for (const capture::FrameRecord& f : bracket) ev.push_back(f.exposure.ev_compensation);
      const calibration::EvCalibration ev_cal = calibration::RecoverResponseFromEv(frames, ev, response_options);
      summary = ev_cal.result.summary;
      response = ev_cal.result.response;
      times = ev_cal.exposure_times_s;
    } else {
      const calibration::ResponseResult r = calibration::RecoverResponse(frames, times, response_options);
      summary = r.summary;
      response = r.response;
    }
    if (!summary.usable) {
      throw InvalidArgumentError(name + ": the response cannot be recovered from this bracket: " + summary.reason);
    }
    out.response_source = "recovered from the bracket";
    // A sparse bracket's curve rests on the smoothness prior: say so wherever the source is shown.
    if (summary.low_confidence) out.response_source += ", low confidence (" + summary.reason + ")";
  }
  calibration::HdrMergeResult merged = calibration::MergeHdr(frames, times, response, merge);
  if (profile) merged.radiance = calibration::ApplyProfile(*profile, merged.radiance);
  out.radiance = std::move(merged.radiance);
  out.status = std::move(merged.status);
  return out;
}

std::vector<KnobInfo> WithRadianceKnobs(std::vector<KnobInfo> knobs) {
  for (KnobInfo& k : DescribeKnobs<RadianceKnobs>()) knobs.push_back(std::move(k));
  return knobs;
}

DeviceCalibrations RecordedCalibrations(const capture::SessionReader& session, const std::string& device_id) {
  DeviceCalibrations c;
  const auto profile_record = SessionCalibration(session, device_id, "profile");
  const auto response_record = SessionCalibration(session, device_id, "response");
  if (profile_record) {
    c.profile = profile_record->first;
    c.profile_id = profile_record->second;
  }
  if (response_record) c.response_id = response_record->second;
  if (c.profile && c.profile->response) {
    c.response = c.profile->response;
  } else if (response_record && response_record->first.response) {
    c.response = response_record->first.response;
  }
  return c;
}

BracketRadiance LinearRadiance(PipelineRun& run, const std::vector<capture::FrameRecord>& bracket, bool load) {
  RELUME_CHECK(!bracket.empty());
  const capture::SessionReader& session = run.session();
  BracketRadiance out;
  out.device_id = bracket.front().device_id;
  out.bracket_id = bracket.front().bracket_id;
  out.utc = bracket.front().utc;
  out.sun_azimuth_deg = bracket.front().sun_azimuth_deg;
  out.sun_elevation_deg = bracket.front().sun_elevation_deg;
  for (const capture::FrameRecord& f : bracket) out.frame_ids.push_back(f.id);
  const std::string name =
      out.bracket_id ? "bracket " + std::to_string(*out.bracket_id) : "frame " + std::to_string(bracket.front().id);

  RadianceKnobs knobs = run.ReadKnobs<RadianceKnobs>();
  const calibration::HdrMergeOptions& merge = knobs.merge;
  calibration::ResponseOptions& response_options = knobs.response;
  response_options.smoothness = calibration::ResponseSmoothnessFromString(knobs.response_smoothness);
  std::string why;
  if (!merge.IsValid(&why)) throw InvalidArgumentError("merge settings: " + why);
  if (!response_options.IsValid(&why)) throw InvalidArgumentError("response settings: " + why);

  const DeviceCalibrations calibrations = RecordedCalibrations(session, out.device_id);
  const std::int64_t profile_id = calibrations.profile_id;
  const std::int64_t response_id = calibrations.response_id;
  const std::optional<calibration::CalibrationProfile>& profile = calibrations.profile;
  const std::optional<calibration::CameraResponse>& response = calibrations.response;

  StageKey& key = out.key;
  key.Add("stage", "radiance-v2");
  const std::vector<double> times = RelativeExposures(bracket, name);
  for (std::size_t i = 0; i < bracket.size(); ++i) key.Add("frame", bracket[i].sha256).Add("exposure", times[i]);
  AddKnobsToKey(key, knobs, "radiance");
  key.Add("profile", profile_id).Add("response", response_id);

  // A lens with distortion in the scene model: the merged frame is resampled onto the model's
  // pinhole camera, which the pipelines project through (calibration/undistort.h).
  const SceneModel* model = run.scene_model();
  const SceneModelCamera* lens = model != nullptr ? model->FindCamera(out.device_id) : nullptr;
  const bool undistort = lens != nullptr && calibration::HasDistortion(lens->distortion);
  if (undistort) {
    const PinholeIntrinsics& k = lens->camera.intrinsics;
    key.Add("undistort", "v1").Add("width", k.width).Add("height", k.height);
    key.Add("fx", k.fx).Add("fy", k.fy).Add("cx", k.cx).Add("cy", k.cy);
    std::string coefficients;
    for (const double c : lens->distortion) {
      key.Add("distortion", c);
      coefficients += (coefficients.empty() ? "" : ", ") + std::to_string(c);
    }
    run.Decide(
        "radiance", "choose",
        name + ": undistorting onto the scene model's pinhole camera (k1, k2, p1, p2[, k3] = " + coefficients + ")");
  }

  const bool sensor_linear = bracket.front().encoding == SampleEncoding::kSensorLinear;
  if (bracket.size() == 1) {
    run.Decide("radiance", "skip", name + ": single exposure, linearised without a merge");
  }
  if (!sensor_linear && !response) {
    if (bracket.size() < 2) {
      throw InvalidArgumentError(name + " of " + out.device_id +
                                 " is a single camera-encoded frame and the session has no response for the device: "
                                 "record one with `relume calibrate response --session " +
                                 session.dir().string() + "` or capture brackets");
    }
    run.Decide("radiance", "choose",
               name + ": no response recorded for " + out.device_id + "; recovering it from the bracket (" +
                   (IsEvOnly(bracket) ? "EV-only: Debevec-Malik with per-image scales" : "Debevec-Malik") + ")");
  }
  if (profile)
    run.Decide("radiance", "choose",
               name + ": applying colour profile (calibration " + std::to_string(profile_id) + ")");

  const StageStore::Result stage = run.RunStage("radiance", key, [&](const fs::path& dir) {
    LinearisedBracket linear = LineariseBracket(session, bracket, response, profile, merge, response_options);
    if (undistort) {
      const calibration::Undistorter& undistorter = run.LensUndistorter(lens->camera.intrinsics, lens->distortion);
      linear.radiance = undistorter.Apply(linear.radiance);
      linear.status = undistorter.ApplyNearest(linear.status, calibration::kHdrNoSample);
    }
    calibration::SaveRadianceExr(linear.radiance, (dir / "radiance.exr").string());
    calibration::SaveImage(linear.status, (dir / "status.png").string());
    calibration::SaveImage(RadiancePreview(linear.radiance), (dir / "preview.png").string());
  });
  out.exr = stage.dir / "radiance.exr";
  if (!load) return out;
  out.radiance = calibration::LoadRadianceExr(out.exr.string());
  out.status = cv::imread((stage.dir / "status.png").string(), cv::IMREAD_UNCHANGED);
  return out;
}

cv::Mat RadiancePreview(const RadianceImage& radiance, double white) {
  RELUME_CHECK(radiance.pixels.type() == CV_32FC3);
  if (!(white > 0.0)) {
    std::vector<float> lum;
    lum.reserve(radiance.pixels.total());
    for (int y = 0; y < radiance.height(); ++y) {
      const auto* p = radiance.pixels.ptr<cv::Vec3f>(y);
      for (int x = 0; x < radiance.width(); ++x) {
        const float l = 0.2126f * p[x][0] + 0.7152f * p[x][1] + 0.0722f * p[x][2];
        if (std::isfinite(l)) lum.push_back(l);
      }
    }
    if (!lum.empty()) {
      const std::size_t k = lum.size() * 99 / 100;
      std::nth_element(lum.begin(), lum.begin() + static_cast<std::ptrdiff_t>(k), lum.end());
      white = lum[k];
    }
    if (!(white > 0.0)) white = 1.0;
  }
  cv::Mat out(radiance.height(), radiance.width(), CV_8UC3);
  for (int y = 0; y < radiance.height(); ++y) {
    const auto* p = radiance.pixels.ptr<cv::Vec3f>(y);
    auto* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < radiance.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        const double v = std::isfinite(p[x][c]) ? std::clamp(p[x][c] / white, 0.0, 1.0) : 0.0;
        const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
        o[x][c] = static_cast<std::uint8_t>(std::lround(255.0 * s));
      }
    }
  }
  return out;
}

}  // namespace relume::pipeline
