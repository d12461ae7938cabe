// Session playback (librealsense's playback_device): each device of a recorded session
// (SessionReader) becomes a drivers::StillCamera or drivers::RgbdSensor that returns the
// recorded frames, in recorded order, with their recorded file bytes (StillFrame::
// original_file, so a re-recording stores the same bytes and SHA-256), exposure records,
// host and device timestamps and sequence numbers. It lives in capture/ because it reads
// sessions; drivers/ does not know sessions.
//
// Conventions:
//  - Backend name "playback"; a device's id is its recorded full id ("sim:dslr"), so it
//    lists as "playback:sim:dslr". Times in the frames are the recorded ones, not the clock's.
//  - Still cameras: capabilities() offers exactly the exposures that were recorded (shutter
//    list of recorded times, or EV-only with the recorded EV steps; recorded apertures and
//    ISOs). Apply() of a value never recorded throws DeviceError(kUnsupportedSetting) naming
//    what was recorded. Capture() plays the next frame of the current bracket: with an
//    exposure applied, the unplayed frame of that bracket with that exposure (kNotFound,
//    naming the bracket and what it holds, when it has none); without, the next in order.
//    A bracket whose frames have all been played gives way to the next one.
//  - The recorder does not meter or plan for a playback camera: it asks
//    RecordedBrackets::Next() for the exposures of the next recorded bracket and requests
//    exactly those (recorder.h), so a replayed session has the same brackets.
//  - RGB-D sensors: depth and colour rows written together are one RgbdFrame; intrinsics and
//    registration come from the session's "rgbd_geometry" calibration rows
//    (rgbd_geometry.h). Playback resumes where it stopped across Stop()/Start(); the end of
//    the recording is kTimeout (as OpenNI2's file playback). Pacing: as fast as read, or,
//    with PlaybackOptions::clock, at the recorded intervals on that clock.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "capture/session.h"
#include "core/clock.h"
#include "drivers/backend.h"

namespace relume::capture {

struct PlaybackOptions {
  // RGB-D frames are released at their recorded intervals on this clock (from the first frame
  // played after Start); null = as fast as they are read.
  std::shared_ptr<Clock> clock;
  bool verify_checksums = true;  // each file against its recorded SHA-256 (kCorruptFrame if not)
};

// One recorded bracket, as the recorder replays it.
struct RecordedBracket {
  std::int64_t recorded_id = 0;  // bracket id in the recorded session (0: frames outside brackets)
  int planned_count = 0;
  std::string status;  // as recorded: "complete", "partial", "open"
  std::string reason;
  std::vector<drivers::ExposureSettings> exposures;  // in recorded order
};

// The brackets of one recorded still camera, shared by its playback camera and the recorder.
class RecordedBrackets {
 public:
  virtual ~RecordedBrackets() = default;
  // Moves playback to the next bracket not yet started and returns it; nullopt at the end.
  virtual std::optional<RecordedBracket> Next() = 0;
};

class PlaybackBackend : public drivers::Backend {
 public:
  // Throws IoError when `session_dir` holds no session.
  explicit PlaybackBackend(const std::filesystem::path& session_dir, PlaybackOptions options = {});
  std::string name() const override { return "playback"; }
  std::vector<drivers::DeviceInfo> Enumerate() override;
  // Throws DeviceError(kNotFound) for a device the session does not hold, saying which it holds.
  std::unique_ptr<drivers::StillCamera> OpenStillCamera(const drivers::DeviceInfo& info) override;
  std::unique_ptr<drivers::RgbdSensor> OpenRgbdSensor(const drivers::DeviceInfo& info) override;

  const std::filesystem::path& session_dir() const;

  struct Recording;

 private:
  std::shared_ptr<const Recording> recording_;
  PlaybackOptions options_;
};

// The calibrations a session recorded through playback inherits from the recorded session, so
// that processing the replay uses what processing the recording used. `device_ids` maps each
// played device's recorded full id ("sim:rgbd") to its id in the new session
// ("playback:sim:rgbd"). Carried, in the recorded order and with their creation times:
//  - each played device's "response" and "profile" rows (measurements of the camera, which the
//    replayed frames share byte for byte);
//  - the latest scene model, its cameras renamed; cameras of devices not played are left out.
// Not carried: rgbd_geometry rows (the writer stores them with the replayed frames) and rows of
// devices not played. Source frame ids are dropped: they name frames of the recorded session.
// `with_scene_model` false: no scene model (a rig with a simulated world stores its own).
// IoError when a scene model row is unreadable.
std::vector<CalibrationRecord> CarriedCalibrations(const SessionReader& recorded,
                                                   const std::map<std::string, std::string>& device_ids,
                                                   bool with_scene_model = true);

// A recorded still camera played back; recorded_brackets() is what the recorder follows.
class PlaybackStillCamera : public drivers::StillCamera {
 public:
  const drivers::DeviceInfo& info() const override { return info_; }
  drivers::ExposureCapabilities capabilities() const override { return capabilities_; }
  void Apply(const drivers::ExposureSettings& settings) override;
  drivers::StillFrame Capture() override;
  std::shared_ptr<RecordedBrackets> recorded_brackets() const;

  struct State;
  PlaybackStillCamera(std::shared_ptr<const PlaybackBackend::Recording> recording, const drivers::DeviceInfo& info,
                      const PlaybackOptions& options);
  ~PlaybackStillCamera() override;

 private:
  std::shared_ptr<State> state_;
  std::shared_ptr<const PlaybackBackend::Recording> recording_;
  drivers::DeviceInfo info_;
  drivers::ExposureCapabilities capabilities_;
  drivers::ExposureSettings requested_;
  PlaybackOptions options_;
};

}  // namespace relume::capture
