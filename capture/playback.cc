#include "capture/playback.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "capture/rgbd_geometry.h"
#include "capture/scene_model_record.h"
#include "core/error.h"
#include "drivers/device_error.h"

namespace relume::capture {

namespace {

using drivers::DeviceError;
using drivers::DeviceErrorKind;

bool Near(double a, double b, double relative) {
  return std::abs(a - b) <= relative * std::max(std::abs(a), std::abs(b));
}

std::string Seconds(double t) {
  std::ostringstream s;
  if (!std::isfinite(t)) return "unknown";
  if (t < 1.0 && t > 0.0 && std::abs(1.0 / t - std::round(1.0 / t)) < 0.02 / t) {
    s << "1/" << std::round(1.0 / t) << " s";
  } else {
    s << t << " s";
  }
  return s.str();
}

std::string DescribeExposure(const drivers::ExposureRecord& e) {
  return std::isfinite(e.exposure_time_s) ? Seconds(e.exposure_time_s)
                                          : std::to_string(e.ev_compensation).substr(0, 5) + " EV";
}

}  // namespace

struct PlaybackBackend::Recording {
  std::shared_ptr<SessionReader> reader;
  std::vector<drivers::DeviceInfo> devices;                // as recorded
  std::map<std::string, std::vector<FrameRecord>> frames;  // by recorded full id, in id order
  std::map<std::int64_t, BracketRecord> brackets;
  std::map<std::string, std::vector<CalibrationRecord>> geometry;  // rgbd_geometry rows by device

  const drivers::DeviceInfo* Find(const std::string& full_id) const {
    for (const auto& d : devices) {
      if (d.FullId() == full_id) return &d;
    }
    return nullptr;
  }
};

PlaybackBackend::PlaybackBackend(const std::filesystem::path& session_dir, PlaybackOptions options)
    : options_(std::move(options)) {
  auto recording = std::make_shared<Recording>();
  recording->reader = std::make_shared<SessionReader>(session_dir);
  recording->devices = recording->reader->Devices();
  for (FrameRecord& f : recording->reader->Frames()) recording->frames[f.device_id].push_back(std::move(f));
  for (BracketRecord& b : recording->reader->Brackets()) recording->brackets[b.id] = std::move(b);
  for (CalibrationRecord& c : recording->reader->Calibrations()) {
    if (c.kind == kRgbdGeometryKind) recording->geometry[c.device_id].push_back(std::move(c));
  }
  recording_ = std::move(recording);
}

const std::filesystem::path& PlaybackBackend::session_dir() const {
  return recording_->reader->dir();
}

std::vector<drivers::DeviceInfo> PlaybackBackend::Enumerate() {
  std::vector<drivers::DeviceInfo> out;
  for (const drivers::DeviceInfo& recorded : recording_->devices) {
    drivers::DeviceInfo info = recorded;
    info.backend = "playback";
    info.id = recorded.FullId();
    info.address = recording_->reader->dir().string();
    info.details["recorded_backend"] = recorded.backend;
    const auto frames = recording_->frames.find(recorded.FullId());
    const std::size_t rows = frames == recording_->frames.end() ? 0 : frames->second.size();
    info.details["recorded_frames"] =
        std::to_string(recorded.kind == drivers::DeviceKind::kRgbdSensor ? rows / 2 : rows);
    out.push_back(std::move(info));
  }
  return out;
}

namespace {

drivers::DeviceInfo FindInfo(const std::vector<drivers::DeviceInfo>& devices, const drivers::DeviceInfo& wanted,
                             const std::filesystem::path& dir) {
  std::string held;
  for (const auto& d : devices) {
    if (d.id == wanted.id) return d;
    held += (held.empty() ? "" : ", ") + d.id;
  }
  throw DeviceError(DeviceErrorKind::kNotFound, wanted.FullId(),
                    "the session " + dir.string() + " has no such device; it holds: " + (held.empty() ? "none" : held));
}

// Reads a frame's file (checked against its SHA-256) as a device error, so a damaged or missing
// file is a fault of the played device, not a storage failure of whoever records it.
std::vector<std::uint8_t> ReadForPlayback(const SessionReader& reader, const FrameRecord& f, bool verify,
                                          const std::string& device_id) {
  try {
    return reader.ReadFrameFile(f, verify);
  } catch (const IoError& e) {
    throw DeviceError(DeviceErrorKind::kCorruptFrame, device_id, std::string("recorded frame unreadable: ") + e.what());
  }
}

drivers::FrameTiming TimingOf(const FrameRecord& f) {
  return {f.utc, f.monotonic, f.device_timestamp, f.sequence};
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Still cameras.

struct PlaybackStillCamera::State : RecordedBrackets {
  struct Group {
    RecordedBracket bracket;
    std::vector<FrameRecord> frames;
    std::vector<bool> played;
    bool Started() const { return std::find(played.begin(), played.end(), true) != played.end(); }
    bool Finished() const { return std::find(played.begin(), played.end(), false) == played.end(); }
  };
  std::mutex mutex;
  std::vector<Group> groups;
  int current = -1;

  std::optional<RecordedBracket> Next() override {
    std::lock_guard<std::mutex> lock(mutex);
    if (current < 0 || groups[static_cast<std::size_t>(current)].Started()) ++current;
    if (current >= static_cast<int>(groups.size())) return std::nullopt;
    return groups[static_cast<std::size_t>(current)].bracket;
  }
};

PlaybackStillCamera::PlaybackStillCamera(std::shared_ptr<const PlaybackBackend::Recording> recording,
                                         const drivers::DeviceInfo& info, const PlaybackOptions& options)
    : state_(std::make_shared<State>()), info_(info), options_(options) {
  const auto found = recording->frames.find(info.id);
  const std::vector<FrameRecord> none;
  const std::vector<FrameRecord>& frames = found == recording->frames.end() ? none : found->second;
  std::set<double> times, evs, apertures, isos;
  bool ev_only = !frames.empty();
  for (const FrameRecord& f : frames) {
    const std::int64_t bracket = f.bracket_id.value_or(0);
    if (bracket == 0 || state_->groups.empty() || state_->groups.back().bracket.recorded_id != bracket) {
      State::Group group;
      group.bracket.recorded_id = bracket;
      if (const auto b = recording->brackets.find(bracket); b != recording->brackets.end()) {
        group.bracket.planned_count = b->second.planned_count;
        group.bracket.status = b->second.status;
        group.bracket.reason = b->second.reason;
      }
      state_->groups.push_back(std::move(group));
    }
    State::Group& group = state_->groups.back();
    drivers::ExposureSettings settings;
    if (std::isfinite(f.exposure.exposure_time_s)) {
      settings.exposure_time_s = f.exposure.exposure_time_s;
      times.insert(f.exposure.exposure_time_s);
      ev_only = false;
    } else {
      settings.ev_compensation = f.exposure.ev_compensation;
    }
    evs.insert(f.exposure.ev_compensation);
    if (std::isfinite(f.exposure.aperture_f)) apertures.insert(f.exposure.aperture_f);
    if (std::isfinite(f.exposure.iso)) isos.insert(f.exposure.iso);
    group.bracket.exposures.push_back(settings);
    group.frames.push_back(f);
    group.played.push_back(false);
  }
  capabilities_.control = ev_only ? drivers::ExposureControl::kEvOnly : drivers::ExposureControl::kShutterList;
  capabilities_.shutter_speeds_s.assign(times.begin(), times.end());
  if (ev_only) capabilities_.ev_steps.assign(evs.begin(), evs.end());
  capabilities_.apertures_f.assign(apertures.begin(), apertures.end());
  capabilities_.iso_values.assign(isos.begin(), isos.end());
  recording_ = std::move(recording);
}

PlaybackStillCamera::~PlaybackStillCamera() = default;

std::shared_ptr<RecordedBrackets> PlaybackStillCamera::recorded_brackets() const {
  return state_;
}

void PlaybackStillCamera::Apply(const drivers::ExposureSettings& s) {
  auto check = [&](const std::optional<double>& value, const std::vector<double>& recorded, const char* what,
                   bool absolute) {
    if (!value) return;
    const bool found = std::any_of(recorded.begin(), recorded.end(), [&](double r) {
      return absolute ? std::abs(r - *value) < 1e-3 : Near(r, *value, 1e-3);
    });
    if (found) return;
    std::ostringstream list;
    for (double r : recorded) list << (list.tellp() > 0 ? ", " : "") << r;
    throw DeviceError(
        DeviceErrorKind::kUnsupportedSetting, info_.FullId(),
        std::string(what) + " " + std::to_string(*value) +
            " was never recorded by this device; recorded: " + (recorded.empty() ? std::string("none") : list.str()));
  };
  check(s.exposure_time_s, capabilities_.shutter_speeds_s, "exposure time (s)", false);
  check(s.ev_compensation, capabilities_.ev_steps, "EV compensation", true);
  check(s.aperture_f, capabilities_.apertures_f, "aperture f/", false);
  check(s.iso, capabilities_.iso_values, "ISO", false);
  if (s.gain_db) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(), "gain is not offered by a played session");
  }
  if (s.exposure_time_s) requested_.exposure_time_s = s.exposure_time_s;
  if (s.ev_compensation) requested_.ev_compensation = s.ev_compensation;
  if (s.aperture_f) requested_.aperture_f = s.aperture_f;
  if (s.iso) requested_.iso = s.iso;
}

drivers::StillFrame PlaybackStillCamera::Capture() {
  FrameRecord record;
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    auto& groups = state_->groups;
    if (state_->current < 0 || groups[static_cast<std::size_t>(state_->current)].Finished()) ++state_->current;
    if (state_->current >= static_cast<int>(groups.size())) {
      state_->current = static_cast<int>(groups.size());
      throw DeviceError(DeviceErrorKind::kNotFound, info_.FullId(), "the recording has no more frames");
    }
    State::Group& group = groups[static_cast<std::size_t>(state_->current)];
    auto matches = [&](const FrameRecord& f) {
      const drivers::ExposureRecord& e = f.exposure;
      if (requested_.exposure_time_s && !Near(e.exposure_time_s, *requested_.exposure_time_s, 1e-3)) return false;
      if (requested_.ev_compensation && !std::isfinite(e.exposure_time_s) &&
          std::abs(e.ev_compensation - *requested_.ev_compensation) >= 1e-3) {
        return false;
      }
      if (requested_.aperture_f && std::isfinite(e.aperture_f) && !Near(e.aperture_f, *requested_.aperture_f, 1e-3)) {
        return false;
      }
      return !(requested_.iso && std::isfinite(e.iso) && !Near(e.iso, *requested_.iso, 1e-3));
    };
    std::size_t i = 0;
    while (i < group.frames.size() && (group.played[i] || !matches(group.frames[i]))) ++i;
    if (i == group.frames.size()) {
      std::string held, left;
      for (std::size_t k = 0; k < group.frames.size(); ++k) {
        const std::string e = DescribeExposure(group.frames[k].exposure);
        held += (held.empty() ? "" : ", ") + e;
        if (!group.played[k]) left += (left.empty() ? "" : ", ") + e;
      }
      drivers::ExposureRecord asked;
      asked.exposure_time_s = requested_.exposure_time_s.value_or(NAN);
      asked.ev_compensation = requested_.ev_compensation.value_or(0.0);
      throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(),
                        "exposure " + DescribeExposure(asked) + " was not recorded in bracket " +
                            std::to_string(group.bracket.recorded_id) + " (it holds " + held +
                            "; not yet played: " + (left.empty() ? std::string("none") : left) + ")");
    }
    group.played[i] = true;
    record = group.frames[i];
  }
  drivers::StillFrame frame;
  frame.device_id = info_.FullId();
  frame.model = info_.model;
  frame.original_file = ReadForPlayback(*recording_->reader, record, options_.verify_checksums, info_.FullId());
  frame.original_format = record.file_format;
  try {
    frame.image = DecodeFrameImage(frame.original_file, record, info_.FullId() + " frame " + record.file_path);
  } catch (const Error& e) {
    frame.undecoded_reason = e.what();  // as the camera delivered it: the file, no pixels
  }
  frame.exposure = record.exposure;
  frame.timing = TimingOf(record);
  frame.sensor_temperature_c = record.sensor_temperature_c;
  return frame;
}

// ---------------------------------------------------------------------------------------------
// RGB-D sensors.

namespace {

class PlaybackRgbdSensor : public drivers::RgbdSensor {
 public:
  PlaybackRgbdSensor(std::shared_ptr<const PlaybackBackend::Recording> recording, drivers::DeviceInfo info,
                     PlaybackOptions options)
      : recording_(std::move(recording)), info_(std::move(info)), options_(std::move(options)) {
    const auto found = recording_->frames.find(info_.id);
    if (found != recording_->frames.end()) {
      const std::vector<FrameRecord>& rows = found->second;
      for (std::size_t i = 0; i + 1 < rows.size(); ++i) {
        if (rows[i].stream == "depth" && rows[i + 1].stream == "color") {
          pairs_.emplace_back(rows[i], rows[i + 1]);
          ++i;
        }
      }
    }
    if (const auto g = recording_->geometry.find(info_.id); g != recording_->geometry.end()) geometry_ = g->second;
    drivers::RgbdStreamConfig config;
    if (!pairs_.empty()) {
      config.depth_width = pairs_.front().first.width;
      config.depth_height = pairs_.front().first.height;
      config.color_width = pairs_.front().second.width;
      config.color_height = pairs_.front().second.height;
      drivers::RgbdFrame first;
      if (!geometry_.empty()) {
        ApplyRgbdGeometryJson(geometry_.front().json, &first);
        config.register_depth_to_color = first.registered_to_color;
      }
      // The recorded rate: the median interval between consecutive frames.
      std::vector<double> intervals;
      for (std::size_t i = 1; i < pairs_.size(); ++i) {
        intervals.push_back(
            std::chrono::duration<double>(pairs_[i].first.monotonic - pairs_[i - 1].first.monotonic).count());
      }
      std::sort(intervals.begin(), intervals.end());
      if (!intervals.empty() && intervals[intervals.size() / 2] > 0.0) {
        config.fps = std::min(1000.0, std::round(1.0 / intervals[intervals.size() / 2]));
      }
    }
    config_ = config;
  }

  const drivers::DeviceInfo& info() const override { return info_; }
  std::vector<drivers::RgbdStreamConfig> SupportedConfigs() const override { return {config_}; }
  void Start(const drivers::RgbdStreamConfig& c) override {
    if (c.depth_width != config_.depth_width || c.depth_height != config_.depth_height ||
        c.color_width != config_.color_width || c.color_height != config_.color_height) {
      throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(),
                        "the recording holds depth " + std::to_string(config_.depth_width) + "x" +
                            std::to_string(config_.depth_height) + " + colour " + std::to_string(config_.color_width) +
                            "x" + std::to_string(config_.color_height) + " only");
    }
    streaming_ = true;
    paced_from_.reset();
  }
  void Stop() override { streaming_ = false; }
  bool streaming() const override { return streaming_; }

  drivers::RgbdFrame WaitForFrame(Nanoseconds timeout) override {
    if (!streaming_) throw DeviceError(DeviceErrorKind::kTimeout, info_.FullId(), "not streaming");
    if (next_ >= pairs_.size()) {
      throw DeviceError(DeviceErrorKind::kTimeout, info_.FullId(),
                        "end of the recording (" + std::to_string(pairs_.size()) + " frames played)");
    }
    const auto& [depth, color] = pairs_[next_];
    if (options_.clock) Pace(depth.monotonic, timeout);
    ++next_;
    drivers::RgbdFrame frame;
    frame.device_id = info_.FullId();
    // The files as recorded, and the pixels decoded from them: storing the frame again keeps the
    // files byte for byte (SessionWriter::WriteRgbdFrames), as a still camera's do.
    const SessionReader& reader = *recording_->reader;
    frame.depth_file.bytes = ReadForPlayback(reader, depth, options_.verify_checksums, info_.FullId());
    frame.depth_file.format = depth.file_format;
    frame.color_file.bytes = ReadForPlayback(reader, color, options_.verify_checksums, info_.FullId());
    frame.color_file.format = color.file_format;
    try {
      frame.depth_m = DecodeDepthFrame(frame.depth_file.bytes, depth, (reader.dir() / depth.file_path).string(),
                                       &frame.depth_file.depth_samples_per_metre);
      frame.color = DecodeFrameImage(frame.color_file.bytes, color, (reader.dir() / color.file_path).string());
    } catch (const Error& e) {
      throw DeviceError(DeviceErrorKind::kCorruptFrame, info_.FullId(),
                        std::string("recorded frame unreadable: ") + e.what());
    }
    if (const CalibrationRecord* g = RgbdGeometryAt(geometry_, info_.id, depth.id))
      ApplyRgbdGeometryJson(g->json, &frame);
    frame.depth_timing = TimingOf(depth);
    frame.color_timing = TimingOf(color);
    frame.color_exposure = color.exposure;  // the exposure the sensor reported, as recorded
    return frame;
  }

 private:
  // Releases the frame recorded at `recorded` at the same offset from the first frame played
  // since Start, on the playback clock.
  void Pace(MonotonicTime recorded, Nanoseconds timeout) {
    Clock& clock = *options_.clock;
    if (!paced_from_) paced_from_ = std::make_pair(clock.NowMonotonic(), recorded);
    const MonotonicTime due = paced_from_->first + (recorded - paced_from_->second);
    const Nanoseconds wait = due - clock.NowMonotonic();
    if (wait <= Nanoseconds{0}) return;
    if (wait > timeout) {
      clock.SleepFor(timeout);
      throw DeviceError(DeviceErrorKind::kTimeout, info_.FullId(), "the next recorded frame is later than the timeout");
    }
    clock.SleepFor(wait);
  }

  std::shared_ptr<const PlaybackBackend::Recording> recording_;
  drivers::DeviceInfo info_;
  PlaybackOptions options_;
  std::vector<std::pair<FrameRecord, FrameRecord>> pairs_;
  std::vector<CalibrationRecord> geometry_;
  drivers::RgbdStreamConfig config_;
  std::size_t next_ = 0;
  bool streaming_ = false;
  std::optional<std::pair<MonotonicTime, MonotonicTime>> paced_from_;  // (clock, recorded) at the first frame
};

}  // namespace

std::unique_ptr<drivers::StillCamera> PlaybackBackend::OpenStillCamera(const drivers::DeviceInfo& wanted) {
  const drivers::DeviceInfo info = FindInfo(Enumerate(), wanted, session_dir());
  if (info.kind != drivers::DeviceKind::kStillCamera) {
    throw InvalidArgumentError(info.FullId() + " is an RGB-D sensor, not a still camera");
  }
  return std::make_unique<PlaybackStillCamera>(recording_, info, options_);
}

std::unique_ptr<drivers::RgbdSensor> PlaybackBackend::OpenRgbdSensor(const drivers::DeviceInfo& wanted) {
  const drivers::DeviceInfo info = FindInfo(Enumerate(), wanted, session_dir());
  if (info.kind != drivers::DeviceKind::kRgbdSensor) {
    throw InvalidArgumentError(info.FullId() + " is a still camera, not an RGB-D sensor");
  }
  return std::make_unique<PlaybackRgbdSensor>(recording_, info, options_);
}

std::vector<CalibrationRecord> CarriedCalibrations(const SessionReader& recorded,
                                                   const std::map<std::string, std::string>& device_ids,
                                                   bool with_scene_model) {
  const std::vector<CalibrationRecord> rows = recorded.Calibrations();
  std::vector<CalibrationRecord> out;
  for (const CalibrationRecord& row : rows) {
    if (row.kind != "response" && row.kind != "profile") continue;
    const auto played = device_ids.find(row.device_id);
    if (played == device_ids.end()) continue;
    CalibrationRecord copy = row;
    copy.id = 0;
    copy.device_id = played->second;
    copy.source_frame_ids.clear();
    out.push_back(std::move(copy));
  }
  const CalibrationRecord* row = with_scene_model ? LatestSceneModelRow(rows) : nullptr;
  if (row != nullptr) {
    SceneModel model =
        SceneModelFromJson(row->json, "calibration row " + std::to_string(row->id) + " of " + recorded.dir().string());
    std::vector<SceneModelCamera> cameras;
    for (SceneModelCamera& camera : model.cameras) {
      const auto played = device_ids.find(camera.device_id);
      if (played == device_ids.end()) continue;
      camera.device_id = played->second;
      cameras.push_back(std::move(camera));
    }
    model.cameras = std::move(cameras);
    CalibrationRecord copy = *row;
    copy.id = 0;
    copy.json = SceneModelToJson(model);
    copy.source_frame_ids.clear();
    out.push_back(std::move(copy));
  }
  return out;
}

}  // namespace relume::capture
