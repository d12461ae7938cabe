// The recorder: runs a rig's still cameras on a schedule (meter, plan a bracket, capture it)
// and streams its RGB-D sensors, storing everything through one SessionWriter.
//
// Faults never crash a capture. Still cameras are wrapped in retry (busy, timeout, I/O,
// corrupt frame) and reconnect (disconnect) wrappers whose every retry becomes a session
// event; a bracket that cannot finish is recorded as "partial" with the reason. RGB-D streams
// reconnect and restart. A storage error (disk full, folder gone) stops the whole capture
// cleanly: everything acknowledged before it stays valid, and Run() reports why it stopped.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "capture/bracket_planner.h"
#include "capture/schedule.h"
#include "capture/session.h"
#include "core/clock.h"
#include "drivers/retry.h"
#include "drivers/rgbd_sensor.h"
#include "drivers/still_camera.h"

namespace relume::capture {

struct RecorderOptions {
  ScheduleOptions schedule;
  BracketPlannerOptions bracket;
  drivers::RetryPolicy retry;
  // Stop after this much clock time (nothing = when the schedule ends and no RGB-D sensor runs).
  std::optional<Nanoseconds> duration;
  int max_dark_extensions = 3;  // adaptive extra dark frames per bracket
  int rgbd_queue_frames = 64;   // frames buffered between an RGB-D sensor and the disk
  int rgbd_batch_frames = 8;    // most queued RGB-D frames acknowledged by one group commit
  bool IsValid(std::string* why) const;
};

struct RecorderStatus {
  std::int64_t still_frames = 0;
  std::int64_t rgbd_frames = 0;
  std::int64_t brackets = 0;
  std::int64_t partial_brackets = 0;
  std::int64_t faults = 0;        // device errors seen (retries included)
  std::int64_t rgbd_dropped = 0;  // frames the recorder could not store in time (queue full)
  // Of the last streamed RGB-D frame stored: host steady time from its arrival at the recorder
  // (WaitForFrame returned) to its acknowledgement (queue wait + encode + durable write).
  Nanoseconds rgbd_last_latency{0};
  std::uint64_t bytes_written = 0;
  std::optional<UtcTime> next_trigger;
  UtcTime now;
};

// Streamed RGB-D frames, arrival at the recorder to acknowledgement (1 ms resolution).
struct LatencySummary {
  std::int64_t frames = 0;
  double p50_ms = 0.0;
  double p90_ms = 0.0;
  double p99_ms = 0.0;
  double max_ms = 0.0;
};

// Fixed memory whatever the run's length: 1 ms bins up to 60 s (later ones in the last bin).
class LatencyHistogram {
 public:
  void Add(Nanoseconds latency);
  LatencySummary Summary() const;

 private:
  static constexpr std::int64_t kBins = 60000;
  std::vector<std::int64_t> bins_ = std::vector<std::int64_t>(kBins, 0);
  std::int64_t count_ = 0;
  Nanoseconds max_{0};
};

struct RecorderSummary {
  RecorderStatus status;
  LatencySummary rgbd_latency;
  bool stopped_by_user = false;
  bool storage_failed = false;
  std::string stop_reason;
};

// How to get a device again after it disconnected (typically DeviceRegistry::Find + Open).
using StillCameraOpener = std::function<std::unique_ptr<drivers::StillCamera>()>;
using RgbdSensorOpener = std::function<std::unique_ptr<drivers::RgbdSensor>()>;

class Recorder {
 public:
  Recorder(SessionWriter& writer, Clock& clock, const RecorderOptions& options);
  ~Recorder();

  // Registers the device in the session and wraps it in retry/reconnect wrappers.
  void AddStillCamera(std::unique_ptr<drivers::StillCamera> camera, StillCameraOpener reopen);
  // burst_frames = 0: stream continuously for the whole run; > 0: record that many frames at
  // every trigger (sessions of hours on a fast simulated clock would otherwise be enormous).
  void AddRgbdSensor(std::unique_ptr<drivers::RgbdSensor> sensor, RgbdSensorOpener reopen,
                     const drivers::RgbdStreamConfig& config, int burst_frames = 0);

  // Runs until the schedule and duration end, `stop` becomes true, or storage fails.
  // `progress` is called after every stored still frame, after every group commit of streamed
  // RGB-D frames and at every trigger (from the calling thread for stills and from the writer
  // thread for RGB-D; keep it cheap).
  RecorderSummary Run(const std::atomic<bool>& stop, const std::function<void(const RecorderStatus&)>& progress = {});

 private:
  struct StillDevice;
  struct RgbdDevice;
  void CaptureBracket(StillDevice& device);
  std::optional<BracketPlan> RecordedPlan(StillDevice& device, std::string* recorded_partial);
  void StoreBracket(StillDevice& device, const BracketPlan& plan, bool extend_darker, const std::string& known_partial);
  void RecordEvent(const std::string& device_id, const std::string& type, const std::string& message);
  void RgbdLoop(RgbdDevice& device, const std::atomic<bool>& stop);
  void RecordBurst(RgbdDevice& device);
  void StorageFailed(const std::string& message);
  bool PlayedOut() const;
  RecorderStatus Snapshot();

  SessionWriter& writer_;
  Clock& clock_;
  RecorderOptions options_;
  std::vector<std::unique_ptr<StillDevice>> stills_;
  std::vector<std::unique_ptr<RgbdDevice>> rgbds_;
  std::mutex mutex_;  // guards writer_ and status_
  RecorderStatus status_;
  LatencyHistogram rgbd_latency_;
  std::atomic<bool> storage_failed_{false};
  std::string storage_message_;
  std::function<void(const RecorderStatus&)> progress_;
};

}  // namespace relume::capture
