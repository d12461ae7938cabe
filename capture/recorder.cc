#include "capture/recorder.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <sstream>
#include <thread>

#include "capture/playback.h"
#include "core/error.h"

namespace relume::capture {

struct Recorder::StillDevice {
  drivers::DeviceInfo info;
  std::unique_ptr<drivers::StillCamera> camera;  // wrapped: retries inside reconnects
  drivers::ExposureCapabilities caps;
  double metering_time_s = 1e-3;  // shutter-list and continuous cameras
  double metering_ev = 0.0;       // EV-only cameras
  // A played-back session's camera: its recorded brackets replace metering and planning.
  std::shared_ptr<RecordedBrackets> recorded;
  bool played_out = false;  // `recorded` has no more brackets
};

struct Recorder::RgbdDevice {
  drivers::DeviceInfo info;
  std::unique_ptr<drivers::RgbdSensor> sensor;
  RgbdSensorOpener reopen;
  drivers::RgbdStreamConfig config;
  int burst_frames = 0;
  std::thread reader;
  std::thread storer;
  std::mutex queue_mutex;
  std::condition_variable queue_ready;
  struct Queued {
    drivers::RgbdFrame frame;
    std::chrono::steady_clock::time_point arrived;  // when WaitForFrame returned it
  };
  std::deque<Queued> queue;
  bool reader_done = false;
};

void LatencyHistogram::Add(Nanoseconds latency) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(latency).count();
  ++bins_[static_cast<std::size_t>(std::clamp<std::int64_t>(ms, 0, kBins - 1))];
  ++count_;
  max_ = std::max(max_, latency);
}

LatencySummary LatencyHistogram::Summary() const {
  LatencySummary s;
  s.frames = count_;
  s.max_ms = std::chrono::duration<double, std::milli>(max_).count();
  auto quantile = [&](double q) {
    const auto rank = static_cast<std::int64_t>(std::ceil(q * static_cast<double>(count_)));
    std::int64_t seen = 0;
    for (std::size_t i = 0; i < bins_.size(); ++i) {
      seen += bins_[i];
      if (seen >= std::max<std::int64_t>(rank, 1)) return static_cast<double>(i + 1);  // upper edge of the bin
    }
    return s.max_ms;
  };
  if (count_ > 0) {
    s.p50_ms = std::min(quantile(0.50), s.max_ms);
    s.p90_ms = std::min(quantile(0.90), s.max_ms);
    s.p99_ms = std::min(quantile(0.99), s.max_ms);
  }
  return s;
}

bool RecorderOptions::IsValid(std::string* why) const {
  if (!schedule.IsValid(why) || !bracket.IsValid(why) || !retry.IsValid(why)) return false;
  if (duration && *duration <= Nanoseconds{0}) {
    if (why) *why = "duration must be positive";
    return false;
  }
  if (max_dark_extensions < 0 || rgbd_queue_frames < 1 || rgbd_batch_frames < 1) {
    if (why) *why = "max_dark_extensions must be >= 0, rgbd_queue_frames and rgbd_batch_frames >= 1";
    return false;
  }
  return true;
}

Recorder::Recorder(SessionWriter& writer, Clock& clock, const RecorderOptions& options)
    : writer_(writer), clock_(clock), options_(options) {
  ThrowIfInvalid(options_, "recorder options");
}

Recorder::~Recorder() {
  for (auto& device : rgbds_) {
    if (device->reader.joinable()) device->reader.join();
    if (device->storer.joinable()) device->storer.join();
  }
}

void Recorder::RecordEvent(const std::string& device_id, const std::string& type, const std::string& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (type == "fault" || type == "retry" || type == "gave_up") ++status_.faults;
  if (storage_failed_) return;
  try {
    writer_.AddEvent({0, clock_.NowUtc(), clock_.NowMonotonic(), device_id, type, message});
  } catch (const Error& e) {
    storage_failed_ = true;
    storage_message_ = e.what();
  }
}

void Recorder::StorageFailed(const std::string& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!storage_failed_) storage_message_ = message;
  storage_failed_ = true;
}

RecorderStatus Recorder::Snapshot() {
  std::lock_guard<std::mutex> lock(mutex_);
  status_.bytes_written = writer_.bytes_written();
  status_.now = clock_.NowUtc();
  return status_;
}

namespace {
double InitialMeteringTime(const drivers::ExposureCapabilities& caps) {
  constexpr double kStart = 1.0 / 125;
  if (caps.control == drivers::ExposureControl::kContinuous) {
    return std::clamp(kStart, caps.min_exposure_time_s, caps.max_exposure_time_s);
  }
  if (caps.control == drivers::ExposureControl::kShutterList && !caps.shutter_speeds_s.empty()) {
    return *std::min_element(caps.shutter_speeds_s.begin(), caps.shutter_speeds_s.end(), [](double a, double b) {
      return std::abs(std::log(a / kStart)) < std::abs(std::log(b / kStart));
    });
  }
  return kStart;
}
}  // namespace

void Recorder::AddStillCamera(std::unique_ptr<drivers::StillCamera> camera, StillCameraOpener reopen) {
  RELUME_CHECK(camera != nullptr);
  auto device = std::make_unique<StillDevice>();
  device->info = camera->info();
  device->caps = camera->capabilities();
  device->metering_time_s = InitialMeteringTime(device->caps);
  if (const auto* playback = dynamic_cast<const PlaybackStillCamera*>(camera.get())) {
    device->recorded = playback->recorded_brackets();
  }
  const std::string id = device->info.FullId();
  drivers::DeviceEventSink sink = [this, id](const drivers::DeviceEvent& event) {
    RecordEvent(id, drivers::ToString(event.type),
                std::string(drivers::ToString(event.error)) + " (attempt " + std::to_string(event.attempt) +
                    "): " + event.message);
  };
  auto sleep = [this](Nanoseconds d) { clock_.SleepFor(d); };
  auto reconnecting = std::make_unique<drivers::ReconnectingStillCamera>(
      std::move(camera), [reopen]() { return reopen ? reopen() : nullptr; }, options_.retry, sink, sleep);
  device->camera = std::make_unique<drivers::RetryingStillCamera>(std::move(reconnecting), options_.retry, sink, sleep);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    writer_.AddDevice(device->info);
  }
  stills_.push_back(std::move(device));
}

void Recorder::AddRgbdSensor(std::unique_ptr<drivers::RgbdSensor> sensor, RgbdSensorOpener reopen,
                             const drivers::RgbdStreamConfig& config, int burst_frames) {
  RELUME_CHECK(burst_frames >= 0);
  RELUME_CHECK(sensor != nullptr);
  ThrowIfInvalid(config, "RGB-D stream config");
  auto device = std::make_unique<RgbdDevice>();
  device->info = sensor->info();
  device->sensor = std::move(sensor);
  device->reopen = std::move(reopen);
  device->config = config;
  device->burst_frames = burst_frames;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    writer_.AddDevice(device->info);
  }
  rgbds_.push_back(std::move(device));
}

// The next recorded bracket of a played-back camera, as a plan: exactly the recorded
// exposures, no metering frame, no dark extension (the recorded ones are in the list).
std::optional<BracketPlan> Recorder::RecordedPlan(StillDevice& device, std::string* recorded_partial) {
  const std::optional<RecordedBracket> recorded = device.recorded->Next();
  if (!recorded) {
    if (!device.played_out) RecordEvent(device.info.FullId(), "skip", "the played session has no more brackets");
    device.played_out = true;
    return std::nullopt;
  }
  BracketPlan plan;
  plan.reason = "replaying recorded bracket " + std::to_string(recorded->recorded_id);
  for (const drivers::ExposureSettings& s : recorded->exposures) {
    PlannedExposure e;
    e.exposure_time_s = s.exposure_time_s;
    e.ev_compensation = s.ev_compensation;
    plan.exposures.push_back(e);
  }
  if (recorded->status == "partial") *recorded_partial = "the recorded bracket was partial: " + recorded->reason;
  return plan;
}

void Recorder::CaptureBracket(StillDevice& device) {
  if (device.recorded) {
    std::string recorded_partial;
    const std::optional<BracketPlan> plan = RecordedPlan(device, &recorded_partial);
    if (plan) StoreBracket(device, *plan, /*extend_darker=*/false, recorded_partial);
    return;
  }
  const std::string id = device.info.FullId();
  const bool ev_only = device.caps.control == drivers::ExposureControl::kEvOnly;
  // 1. Meter.
  drivers::ExposureSettings metering_settings;
  if (ev_only) {
    metering_settings.ev_compensation = device.metering_ev;
  } else {
    metering_settings.exposure_time_s = device.metering_time_s;
  }
  std::optional<MeteringStats> metering;
  try {
    device.camera->Apply(metering_settings);
    const drivers::StillFrame frame = device.camera->Capture();
    if (frame.image.IsValid(nullptr)) {
      metering = MeasureMeteringFrame(frame.image, 1.0, options_.bracket);
    } else {
      RecordEvent(id, "fault",
                  "the metering frame (" + frame.original_format + ") cannot be metered: " +
                      (frame.undecoded_reason.empty() ? std::string("no pixels") : frame.undecoded_reason) +
                      ". The bracket is planned without metering; set the camera to a format relume decodes "
                      "(JPEG, TIFF, or a raw format LibRaw reads) for brackets that fit the scene");
    }
  } catch (const drivers::DeviceError& e) {
    RecordEvent(id, "fault", std::string("no metering frame, bracket skipped: ") + e.what());
    return;
  }
  const BracketPlan plan =
      metering ? PlanBracket(*metering, device.caps, device.metering_time_s, device.metering_ev, options_.bracket)
               : PlanUnmeteredBracket(device.caps, device.metering_time_s, device.metering_ev, options_.bracket);
  std::ostringstream planned;
  planned << plan.exposures.size() << " exposures (" << plan.reason << "):";
  for (const PlannedExposure& e : plan.exposures) {
    if (e.exposure_time_s) planned << " " << *e.exposure_time_s << " s";
    if (e.ev_compensation) planned << " " << *e.ev_compensation << " EV";
  }
  RecordEvent(id, "plan", planned.str());
  StoreBracket(device, plan, /*extend_darker=*/true, "");
}

void Recorder::StoreBracket(StillDevice& device, const BracketPlan& plan, bool extend_darker,
                            const std::string& known_partial) {
  const std::string id = device.info.FullId();
  if (plan.exposures.empty()) return;
  if (device.recorded)
    RecordEvent(id, "plan", std::to_string(plan.exposures.size()) + " exposures (" + plan.reason + ")");
  std::int64_t bracket_id = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    try {
      bracket_id = writer_.BeginBracket(id, clock_.NowUtc(), static_cast<int>(plan.exposures.size()));
    } catch (const Error& e) {
      storage_failed_ = true;
      storage_message_ = e.what();
      return;
    }
  }
  int index = 0;
  std::string partial_reason;
  auto capture_one = [&](const PlannedExposure& exposure) -> std::optional<drivers::StillFrame> {
    try {
      device.camera->Apply(exposure.Settings());
      drivers::StillFrame frame = device.camera->Capture();
      std::lock_guard<std::mutex> lock(mutex_);
      writer_.WriteStillFrame(frame, bracket_id, index++);
      ++status_.still_frames;
      return frame;
    } catch (const drivers::DeviceError& e) {
      partial_reason = e.what();
      RecordEvent(id, "fault", std::string("bracket interrupted: ") + e.what());
    } catch (const IoError& e) {
      StorageFailed(e.what());
      partial_reason = std::string("storage failed: ") + e.what();
    } catch (const Error& e) {
      // A frame the writer refuses (no pixels and no camera file): a driver fault, not storage.
      partial_reason = e.what();
      RecordEvent(id, "fault", std::string("frame not stored, bracket interrupted: ") + e.what());
    }
    return std::nullopt;
  };

  for (std::size_t i = 0; i < plan.exposures.size() && partial_reason.empty(); ++i) {
    const std::optional<drivers::StillFrame> frame = capture_one(plan.exposures[i]);
    if (progress_) progress_(Snapshot());
    if (!frame || i != 0 || !extend_darker || !frame->image.IsValid(nullptr)) continue;
    // Adaptive range: while the darkest frame clips, add darker ones.
    PlannedExposure darkest = plan.exposures[0];
    MeteringStats stats = MeasureMeteringFrame(frame->image, darkest.relative_exposure, options_.bracket);
    for (int extension = 0; extension < options_.max_dark_extensions && partial_reason.empty(); ++extension) {
      const std::optional<PlannedExposure> extra =
          ExtendDarker(stats, darkest, device.caps, device.metering_time_s, device.metering_ev, options_.bracket);
      if (!extra) break;
      RecordEvent(id, "plan",
                  "darkest frame clips: one more exposure at relative " + std::to_string(extra->relative_exposure));
      const std::optional<drivers::StillFrame> extra_frame = capture_one(*extra);
      if (!extra_frame || !extra_frame->image.IsValid(nullptr)) break;
      darkest = *extra;
      stats = MeasureMeteringFrame(extra_frame->image, darkest.relative_exposure, options_.bracket);
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++status_.brackets;
    if (partial_reason.empty()) partial_reason = known_partial;
    if (!partial_reason.empty()) ++status_.partial_brackets;
    if (!storage_failed_) {
      try {
        writer_.EndBracket(bracket_id, partial_reason.empty() ? "complete" : "partial", partial_reason);
      } catch (const Error& e) {
        storage_failed_ = true;
        storage_message_ = e.what();
      }
    }
  }
  // Meter the next bracket from the middle of this one.
  const PlannedExposure& middle = plan.exposures[plan.exposures.size() / 2];
  if (middle.exposure_time_s) device.metering_time_s = *middle.exposure_time_s;
  if (middle.ev_compensation) device.metering_ev = *middle.ev_compensation;
}

void Recorder::RecordBurst(RgbdDevice& device) {
  const std::string id = device.info.FullId();
  const Nanoseconds timeout = std::chrono::milliseconds(std::max(200, static_cast<int>(4000.0 / device.config.fps)));
  for (int attempt = 1; !device.sensor && attempt <= options_.retry.max_attempts; ++attempt) {
    RecordEvent(id, "reconnect_attempt", "attempt " + std::to_string(attempt));
    clock_.SleepFor(options_.retry.BackoffAfter(attempt));
    try {
      if (device.reopen) device.sensor = device.reopen();
    } catch (const drivers::DeviceError& e) {
      RecordEvent(id, "fault", std::string("reopen failed: ") + e.what());
    }
  }
  if (!device.sensor) {
    RecordEvent(id, "skip", "no RGB-D burst: the sensor is not connected");
    return;
  }
  int stored = 0, failures = 0;
  try {
    device.sensor->Start(device.config);
    while (stored < device.burst_frames && failures < options_.retry.max_attempts && !storage_failed_) {
      try {
        const drivers::RgbdFrame frame = device.sensor->WaitForFrame(timeout);
        std::lock_guard<std::mutex> lock(mutex_);
        writer_.WriteRgbdFrame(frame);
        ++status_.rgbd_frames;
        ++stored;
      } catch (const drivers::DeviceError& e) {
        RecordEvent(id, "fault", e.what());
        ++failures;
        if (e.kind() == drivers::DeviceErrorKind::kDisconnected) break;
      }
    }
    device.sensor->Stop();
  } catch (const drivers::DeviceError& e) {
    RecordEvent(id, "fault", e.what());
    if (e.kind() == drivers::DeviceErrorKind::kDisconnected || e.kind() == drivers::DeviceErrorKind::kNotFound) {
      device.sensor.reset();
    }
  } catch (const IoError& e) {
    StorageFailed(e.what());
  }
  if (stored < device.burst_frames) {
    RecordEvent(
        id, "partial",
        "RGB-D burst stored " + std::to_string(stored) + " of " + std::to_string(device.burst_frames) + " frames");
  }
}

void Recorder::RgbdLoop(RgbdDevice& device, const std::atomic<bool>& stop) {
  const std::string id = device.info.FullId();
  const Nanoseconds timeout = std::chrono::milliseconds(std::max(200, static_cast<int>(4000.0 / device.config.fps)));
  bool started = false;
  int reconnect_attempt = 0;
  while (!stop && !storage_failed_) {
    try {
      if (!device.sensor) {
        if (!device.reopen) break;
        ++reconnect_attempt;
        RecordEvent(id, "reconnect_attempt", "attempt " + std::to_string(reconnect_attempt));
        clock_.SleepFor(options_.retry.BackoffAfter(std::min(reconnect_attempt, 10)));
        device.sensor = device.reopen();
        started = false;
        if (!device.sensor) continue;
        RecordEvent(id, "reconnected", "after " + std::to_string(reconnect_attempt) + " attempts");
        reconnect_attempt = 0;
      }
      if (!started) {
        device.sensor->Start(device.config);
        started = true;
      }
      drivers::RgbdFrame frame = device.sensor->WaitForFrame(timeout);
      const auto arrived = std::chrono::steady_clock::now();
      std::lock_guard<std::mutex> lock(device.queue_mutex);
      if (static_cast<int>(device.queue.size()) >= options_.rgbd_queue_frames) {
        std::lock_guard<std::mutex> status_lock(mutex_);
        ++status_.rgbd_dropped;
        continue;
      }
      device.queue.push_back({std::move(frame), arrived});
      device.queue_ready.notify_one();
    } catch (const drivers::DeviceError& e) {
      RecordEvent(id, "fault", e.what());
      if (e.kind() == drivers::DeviceErrorKind::kDisconnected || e.kind() == drivers::DeviceErrorKind::kNotFound) {
        device.sensor.reset();
      }
    }
  }
  if (device.sensor && started) {
    try {
      device.sensor->Stop();
    } catch (const drivers::DeviceError& e) {
      RecordEvent(id, "fault", std::string("stop failed: ") + e.what());
    }
  }
  std::lock_guard<std::mutex> lock(device.queue_mutex);
  device.reader_done = true;
  device.queue_ready.notify_all();
}

// A rig of played-back still cameras only ends with the played session, whatever its
// schedule says (without one it would trigger, and log "no more brackets", forever).
bool Recorder::PlayedOut() const {
  return !stills_.empty() && rgbds_.empty() &&
         std::all_of(stills_.begin(), stills_.end(), [](const auto& d) { return d->recorded && d->played_out; });
}

RecorderSummary Recorder::Run(const std::atomic<bool>& stop,
                              const std::function<void(const RecorderStatus&)>& progress) {
  progress_ = progress;
  RecorderSummary summary;
  const UtcTime start = clock_.NowUtc();
  const bool has_end = options_.duration.has_value();
  const UtcTime end = has_end ? start + *options_.duration : UtcTime::max();
  RecordEvent("", "start", "recording started");

  std::atomic<bool> stop_streams{false};
  for (auto& device_ptr : rgbds_) {
    RgbdDevice& device = *device_ptr;
    if (device.burst_frames > 0) continue;  // recorded at the triggers
    device.reader = std::thread([this, &device, &stop_streams] { RgbdLoop(device, stop_streams); });
    device.storer = std::thread([this, &device] {
      while (true) {
        std::unique_lock<std::mutex> lock(device.queue_mutex);
        device.queue_ready.wait(lock, [&] { return !device.queue.empty() || device.reader_done; });
        if (device.queue.empty()) return;
        // Everything waiting (up to a batch) is acknowledged together: one group commit.
        std::vector<RgbdDevice::Queued> batch;
        while (!device.queue.empty() && static_cast<int>(batch.size()) < options_.rgbd_batch_frames) {
          batch.push_back(std::move(device.queue.front()));
          device.queue.pop_front();
        }
        lock.unlock();
        if (storage_failed_) continue;  // drain without writing
        std::vector<drivers::RgbdFrame> frames;
        for (RgbdDevice::Queued& q : batch) frames.push_back(std::move(q.frame));
        try {
          {
            std::lock_guard<std::mutex> writer_lock(mutex_);
            writer_.WriteRgbdFrames(frames);
            const auto acknowledged = std::chrono::steady_clock::now();
            status_.rgbd_frames += static_cast<std::int64_t>(frames.size());
            for (const RgbdDevice::Queued& q : batch) rgbd_latency_.Add(acknowledged - q.arrived);
            status_.rgbd_last_latency = acknowledged - batch.front().arrived;
          }
          if (progress_) progress_(Snapshot());
        } catch (const Error& e) {
          StorageFailed(e.what());
        }
      }
    });
  }

  const Schedule schedule(options_.schedule, writer_.site());
  std::optional<UtcTime> previous;
  int triggers = 0;
  while (!stop && !storage_failed_) {
    const UtcTime now = clock_.NowUtc();
    if (has_end && now >= end) {
      summary.stop_reason = "the requested duration has passed";
      break;
    }
    const bool triggered_devices = !stills_.empty() || std::any_of(rgbds_.begin(), rgbds_.end(),
                                                                   [](const auto& d) { return d->burst_frames > 0; });
    std::optional<UtcTime> next = triggered_devices ? schedule.Next(now, previous, triggers) : std::nullopt;
    const bool streaming =
        std::any_of(rgbds_.begin(), rgbds_.end(), [](const auto& d) { return d->burst_frames == 0; });
    if (!next && (!streaming || !has_end)) {
      summary.stop_reason = triggered_devices || streaming ? "the schedule is complete" : "nothing to record";
      break;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status_.next_trigger = next;
    }
    const UtcTime wake = next ? std::min(*next, end) : end;
    if (wake > now) {
      clock_.SleepFor(std::min<Nanoseconds>(wake - now, std::chrono::seconds(10)));
      if (progress) progress(Snapshot());
      continue;
    }
    if (!next || *next > now) continue;
    previous = now;
    ++triggers;
    for (auto& device : stills_) {
      if (stop || storage_failed_) break;
      CaptureBracket(*device);
    }
    for (auto& device : rgbds_) {
      if (stop || storage_failed_) break;
      if (device->burst_frames > 0) RecordBurst(*device);
    }
    if (progress) progress(Snapshot());
    if (PlayedOut()) {
      summary.stop_reason = "the played session has no more brackets";
      break;
    }
  }
  if (stop && summary.stop_reason.empty()) {
    summary.stopped_by_user = true;
    summary.stop_reason = "stopped by the operator";
  }
  stop_streams = true;
  for (auto& device : rgbds_) {
    if (device->reader.joinable()) device->reader.join();
    if (device->storer.joinable()) device->storer.join();
  }
  if (storage_failed_) {
    summary.storage_failed = true;
    summary.stop_reason = "storage failed: " + storage_message_;
  } else {
    RecordEvent("", "stop", summary.stop_reason);
  }
  summary.status = Snapshot();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    summary.rgbd_latency = rgbd_latency_.Summary();
  }
  progress_ = nullptr;
  return summary;
}

}  // namespace relume::capture
