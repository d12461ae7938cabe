#include "apps/relume/capture_command.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <functional>
#include <iostream>
#include <map>
#include <optional>
#include <vector>

#include "apps/relume/device_backends.h"
#include "capture/playback.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/clock.h"
#include "core/error.h"
#include "drivers/device_error.h"
#include "rig/factory_response.h"
#include "rig/rig_config.h"
#include "rig/scene_model_from_rig.h"

namespace relume::app {

namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) {
  g_stop = true;
}

std::string HumanBytes(std::uint64_t bytes) {
  char text[32];
  if (bytes >= (1ull << 30)) {
    std::snprintf(text, sizeof(text), "%.2f GiB", static_cast<double>(bytes) / (1ull << 30));
  } else {
    std::snprintf(text, sizeof(text), "%.1f MiB", static_cast<double>(bytes) / (1ull << 20));
  }
  return text;
}

// Every backend the rig's devices need, and no other (no discovery on networks the rig does
// not use).
std::shared_ptr<drivers::DeviceRegistry> BuildRigRegistry(const rig::RigConfig& rig,
                                                          const std::shared_ptr<Clock>& clock) {
  DeviceBackendOptions options;
  if (!rig.devices.empty()) {
    options.sim_devices = rig.devices;
    options.sim_truth = rig.world;
    options.sim_clock = clock;
  }
  auto uses = [&](const char* backend) {
    return std::any_of(rig.registry_devices.begin(), rig.registry_devices.end(),
                       [&](const rig::RegistryDeviceSpec& d) { return d.backend == backend; });
  };
  options.gphoto2 = uses("gphoto2");
  options.openni2 = uses("openni2");
  options.aravis = uses("aravis");
  options.usb = false;
  for (const rig::RegistryDeviceSpec& d : rig.registry_devices) {
    // Ports libgphoto2 cannot autodetect (PTP/IP, disk) are opened by model and port.
    if (d.backend == "gphoto2" && !d.model.empty() && !d.port.empty() && d.port.rfind("usb:", 0) != 0) {
      options.gphoto2_cameras.push_back(d.model + "@" + d.port);
    }
  }
  std::vector<std::string> problems;
  auto registry = BuildDeviceRegistry(options, &problems);
  for (const std::string& problem : problems) std::cerr << "relume capture: " << problem << "\n";
  for (const rig::RegistryDeviceSpec& d : rig.registry_devices) {
    if (d.backend != "playback") continue;
    registry->Add(std::make_shared<capture::PlaybackBackend>(d.session));
    break;  // one session per rig (LoadRigConfig checks)
  }
  return registry;
}

}  // namespace

drivers::DeviceInfo ResolveRigDevice(const drivers::DeviceRegistry& registry, const rig::RegistryDeviceSpec& spec) {
  drivers::Backend* backend = nullptr;
  for (const auto& b : registry.backends()) {
    if (b->name() == spec.backend) backend = b.get();
  }
  if (!backend) {
    std::string why = "the " + spec.backend + " backend did not start (see the message above)";
    for (const std::string& left_out : LeftOutBackends()) {
      if (left_out.rfind(spec.backend + " ", 0) == 0) why = "not part of this build: " + left_out;
    }
    throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, spec.Describe(), why);
  }
  const std::vector<drivers::DeviceInfo> devices = backend->Enumerate();
  std::vector<drivers::DeviceInfo> matches;
  std::string seen;
  for (const drivers::DeviceInfo& info : devices) {
    seen += (seen.empty() ? "" : ", ") + info.FullId();
    const bool match = spec.backend == "playback"
                           ? info.id == spec.device
                           : (spec.id.empty() || info.id == spec.id) &&
                                 (spec.model.empty() || info.model == spec.model) &&
                                 (spec.serial.empty() || info.serial == spec.serial) &&
                                 (spec.port.empty() || info.address == spec.port) &&
                                 (spec.uri.empty() || info.address == spec.uri || info.id == spec.uri);
    if (match) matches.push_back(info);
  }
  if (matches.size() == 1) return matches.front();
  if (matches.empty()) {
    throw drivers::DeviceError(
        drivers::DeviceErrorKind::kNotFound, spec.Describe(),
        "not present; " + spec.backend + " sees " + (seen.empty() ? std::string("no devices") : seen) +
            ". Check that it is plugged in, powered and not held by another program, and that the rig's keys match "
            "what `relume devices` lists");
  }
  std::string which;
  for (const auto& m : matches) which += (which.empty() ? "" : ", ") + m.FullId();
  throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, spec.Describe(),
                             "matches several devices (" + which + "); add serial or port to the rig file");
}

namespace {

// A rig device opened for the capture, with how to open it again after a disconnect.
struct OpenedDevice {
  std::unique_ptr<drivers::StillCamera> camera;
  capture::StillCameraOpener reopen_camera;
  std::unique_ptr<drivers::RgbdSensor> sensor;
  capture::RgbdSensorOpener reopen_sensor;
  drivers::RgbdStreamConfig stream;
};

// The stream to record from an RGB-D sensor: the one the rig asks for; for a simulated sensor
// the one at its rig camera's size (synchronised; registered unless the sensor offers no
// registration) when offered, so a rig's
// `camera:` size is what gets recorded; otherwise the sensor's first stream.
drivers::RgbdStreamConfig ChooseRgbdStream(const drivers::RgbdSensor& sensor, const rig::RigConfig& rig,
                                           const rig::RegistryDeviceSpec* spec) {
  const std::vector<drivers::RgbdStreamConfig> configs = sensor.SupportedConfigs();
  if (configs.empty()) {
    throw drivers::DeviceError(drivers::DeviceErrorKind::kUnsupportedSetting, sensor.info().FullId(),
                               "offers no depth + colour stream");
  }
  if (spec && spec->stream) {
    std::string offered;
    for (const drivers::RgbdStreamConfig& c : configs) {
      if (spec->stream->Matches(c)) return c;
      offered += "\n  " + c.Describe();
    }
    throw drivers::DeviceError(drivers::DeviceErrorKind::kUnsupportedSetting, spec->Describe(),
                               "offers no stream with " + spec->stream->Describe() +
                                   "; change `stream:` in the rig to one it offers:" + offered);
  }
  for (const sim::SimDeviceSpec& sim_spec : rig.devices) {
    if (spec || sim_spec.id != sensor.info().id) continue;
    // Registered when the sensor can (a sensor configured with `registration: none` cannot).
    for (const bool registered : {true, false}) {
      for (const drivers::RgbdStreamConfig& c : configs) {
        if (c.depth_width == sim_spec.camera.intrinsics.width && c.depth_height == sim_spec.camera.intrinsics.height &&
            c.register_depth_to_color == registered && c.sync_depth_and_color) {
          return c;
        }
      }
    }
  }
  return configs.front();
}

// Opens a rig device; `spec` is null for simulated devices. The rig's camera settings are set
// again on every reconnect.
OpenedDevice OpenRigDevice(const std::shared_ptr<drivers::DeviceRegistry>& registry, const drivers::DeviceInfo& device,
                           std::function<drivers::DeviceInfo()> find_again, const rig::RegistryDeviceSpec* spec,
                           const rig::RigConfig& rig) {
  OpenedDevice out;
  if (device.kind == drivers::DeviceKind::kStillCamera) {
    if (spec && spec->stream) {
      throw drivers::DeviceError(drivers::DeviceErrorKind::kUnsupportedSetting, spec->Describe(),
                                 "is a still camera: `stream:` is for RGB-D sensors; remove it from the rig");
    }
    const std::vector<std::pair<std::string, std::string>> settings =
        spec ? spec->camera_settings : std::vector<std::pair<std::string, std::string>>{};
    out.camera = OpenStillCameraWithSettings(*registry, device, settings);
    out.reopen_camera = [registry, find_again, settings]() {
      return OpenStillCameraWithSettings(*registry, find_again(), settings);
    };
  } else {
    out.sensor = registry->OpenRgbdSensor(device);
    out.stream = ChooseRgbdStream(*out.sensor, rig, spec);
    out.reopen_sensor = [registry, find_again]() { return registry->OpenRgbdSensor(find_again()); };
  }
  return out;
}

// The rig, with --duration and --speedup (checked) in place of its own.
rig::RigConfig LoadCaptureRig(const CaptureRequest& request) {
  rig::RigConfig rig = rig::LoadRigConfig(request.rig_path);
  // Checked before the narrowing to int64 nanoseconds (292 years) below.
  if (!(request.duration_minutes >= 0.0 && request.duration_minutes <= 100.0 * 365.25 * 1440.0)) {
    throw InvalidArgumentError("--duration must be within [0, 100 years] in minutes");
  }
  if (!(request.speedup >= 0.0 && request.speedup <= 1e6))
    throw InvalidArgumentError("--speedup must be within (0, 1e6]");
  if (request.duration_minutes > 0.0) {
    rig.recorder.duration = std::chrono::duration_cast<Nanoseconds>(
        std::chrono::duration<double, std::ratio<60>>(request.duration_minutes));
  }
  if (request.speedup > 0.0) rig.clock_speedup = request.speedup;
  return rig;
}

// The capture's clock: the host's, a simulated one running `clock_speedup` times real time, or
// an event-driven simulated one.
std::shared_ptr<Clock> MakeCaptureClock(const rig::RigConfig& rig) {
  if (rig.host_clock) return std::make_shared<SystemClock>();
  if (rig.clock_speedup > 0.0) return std::make_shared<SimulatedClock>(rig.clock_start, rig.clock_speedup);
  return std::make_shared<ManualClock>(
      rig.clock_start, "simulated, event-driven, from " + FormatIso8601(rig.clock_start, std::chrono::seconds{0}, 0));
}

// Every device of the rig, found, opened and set up (camera settings, RGB-D stream): the
// simulated ones, then the registry devices.
std::vector<OpenedDevice> OpenRigDevices(const std::shared_ptr<drivers::DeviceRegistry>& registry,
                                         const rig::RigConfig& rig) {
  std::vector<OpenedDevice> opened;
  if (!rig.devices.empty()) {
    for (const auto& backend : registry->backends()) {
      if (backend->name() != "sim") continue;
      for (const drivers::DeviceInfo& device : backend->Enumerate()) {
        const std::string id = device.FullId();
        opened.push_back(OpenRigDevice(
            registry, device, [registry, id]() { return registry->Find(id); }, nullptr, rig));
      }
    }
  }
  for (const rig::RegistryDeviceSpec& spec : rig.registry_devices) {
    opened.push_back(OpenRigDevice(
        registry, ResolveRigDevice(*registry, spec), [registry, spec]() { return ResolveRigDevice(*registry, spec); },
        &spec, rig));
  }
  return opened;
}

// A rig that plays a recorded session back: the recorded session's calibrations of the played
// devices go into the new session (capture::CarriedCalibrations), so processing the replay uses
// the responses, profiles and scene model that processing the recording used.
void CarryPlaybackCalibrations(const rig::RigConfig& rig, const std::vector<OpenedDevice>& opened,
                               capture::SessionWriter& writer) {
  std::optional<std::string> session;
  for (const rig::RegistryDeviceSpec& spec : rig.registry_devices) {
    if (spec.backend == "playback") session = spec.session;
  }
  if (!session) return;
  std::map<std::string, std::string> device_ids;
  for (const OpenedDevice& device : opened) {
    const drivers::DeviceInfo& info = device.camera ? device.camera->info() : device.sensor->info();
    if (info.backend == "playback") device_ids[info.id] = info.FullId();
  }
  // A rig that also has a simulated world stores that world's scene model, which must stay the
  // latest (the recorded one would drop its cameras and objects).
  const std::vector<capture::CalibrationRecord> carried =
      capture::CarriedCalibrations(capture::SessionReader(*session), device_ids, /*with_scene_model=*/!rig.world);
  for (const capture::CalibrationRecord& record : carried) writer.AddCalibration(record);
  if (!carried.empty()) {
    std::cerr << "relume capture: " << carried.size() << " calibration row(s) of the played devices carried over from "
              << *session << "\n";
  }
}

// The session folder, with the rig stored beside it (processing finds the geometry and cameras
// there).
std::unique_ptr<capture::SessionWriter> CreateSession(const CaptureRequest& request, const rig::RigConfig& rig,
                                                      const Clock& clock, const std::vector<OpenedDevice>& opened) {
  capture::SessionInfo info;
  info.name = rig.name;
  info.site = rig.site;
  info.rig_config = rig.yaml_text;
  info.software_version = std::string("relume ") + RELUME_VERSION;
  info.clock_name = clock.name();
  info.created_utc = clock.NowUtc();
  std::unique_ptr<capture::SessionWriter> writer = capture::SessionWriter::Create(request.out_dir, info, rig.storage);
  rig::StoreRigWithSession(rig, request.out_dir);
  if (rig.world) {
    // What processing may know of the place (cameras, geometry, lamps), so that it never reads the
    // simulator (rig/scene_model_from_rig.h).
    capture::CalibrationRecord record;
    record.created_utc = info.created_utc;
    record.kind = capture::kSceneModelKind;
    record.json = capture::SceneModelToJson(rig::SceneModelFromRig(rig));
    writer->AddCalibration(record);
    // The simulated RGB-D sensors' colour responses, as their maker would ship them
    // (rig/factory_response.h): processing linearises their single exposures from these rows.
    for (const capture::CalibrationRecord& response : rig::FactoryResponseRecords(rig, info.created_utc))
      writer->AddCalibration(response);
  }
  CarryPlaybackCalibrations(rig, opened, *writer);
  return writer;
}

// The recorder's progress line on stderr. On a terminal the line is rewritten in place at every
// update. Into a log (not a terminal) a line is written when a still frame, bracket or fault is
// added, and otherwise (RGB-D frames streaming in, the recorder waiting for its next trigger,
// which on a simulated clock reports many times a second) at most every 10 s of wall time.
class ProgressLine {
 public:
  ProgressLine(bool enabled, bool tty) : enabled_(enabled), tty_(tty) {}

  void Print(const capture::RecorderStatus& s) {
    if (!enabled_) return;
    if (!tty_) {
      const std::array<std::int64_t, 4> counts{s.still_frames, s.brackets, s.partial_brackets, s.faults};
      const auto now = std::chrono::steady_clock::now();
      if (counts == last_counts_ && now - last_line_ < std::chrono::seconds(10)) return;
      last_counts_ = counts;
      last_line_ = now;
    }
    std::fprintf(
        stderr, "%s%s  frames %lld still + %lld rgbd  brackets %lld (%lld partial)  faults %lld  disk %s  next %s%s",
        tty_ ? "\r" : "", FormatIso8601(s.now, std::chrono::seconds{0}, 0).c_str(),
        static_cast<long long>(s.still_frames), static_cast<long long>(s.rgbd_frames),
        static_cast<long long>(s.brackets), static_cast<long long>(s.partial_brackets),
        static_cast<long long>(s.faults), HumanBytes(s.bytes_written).c_str(),
        s.next_trigger ? FormatIso8601(*s.next_trigger, std::chrono::seconds{0}, 0).c_str() : "-", tty_ ? "   " : "\n");
  }

 private:
  bool enabled_;
  bool tty_;
  std::array<std::int64_t, 4> last_counts_{-1, -1, -1, -1};
  std::chrono::steady_clock::time_point last_line_ = std::chrono::steady_clock::now();
};

// What was captured and why it stopped; the exit code (3: storage failed).
int ReportCapture(const CaptureRequest& request, const capture::RecorderSummary& summary) {
  const capture::RecorderStatus& s = summary.status;
  std::cout << "captured " << s.still_frames << " still frames in " << s.brackets << " brackets (" << s.partial_brackets
            << " partial), " << s.rgbd_frames << " RGB-D frames, " << s.faults << " faults, "
            << HumanBytes(s.bytes_written) << " -> " << request.out_dir << "\n"
            << "stopped: " << summary.stop_reason << "\n";
  if (summary.storage_failed) {
    std::cerr << "relume: error: " << summary.stop_reason
              << "\nEvery frame acknowledged before the failure is intact; run `relume session verify "
              << request.out_dir << "`.\n";
    return 3;
  }
  return 0;
}

}  // namespace

int RunCapture(const CaptureRequest& request) {
  const rig::RigConfig rig = LoadCaptureRig(request);
  const std::shared_ptr<Clock> clock = MakeCaptureClock(rig);
  const std::shared_ptr<drivers::DeviceRegistry> registry = BuildRigRegistry(rig, clock);
  // Every device is found, opened and set up (camera settings, RGB-D stream) before a session
  // folder is made: a missing device or a setting the camera refuses leaves nothing behind.
  std::vector<OpenedDevice> opened = OpenRigDevices(registry, rig);
  std::unique_ptr<capture::SessionWriter> writer = CreateSession(request, rig, *clock, opened);

  capture::Recorder recorder(*writer, *clock, rig.recorder);
  for (OpenedDevice& device : opened) {
    if (device.camera) {
      recorder.AddStillCamera(std::move(device.camera), std::move(device.reopen_camera));
    } else {
      recorder.AddRgbdSensor(std::move(device.sensor), std::move(device.reopen_sensor), device.stream,
                             rig.rgbd_burst_frames);
    }
  }

  g_stop = false;
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  const bool tty = request.progress && isatty(STDERR_FILENO);
  ProgressLine progress(request.progress, tty);
  std::cerr << "relume capture: " << rig.name << " -> " << request.out_dir << " (clock " << clock->name() << ")\n";
  const capture::RecorderSummary summary =
      recorder.Run(g_stop, [&progress](const capture::RecorderStatus& s) { progress.Print(s); });
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (tty) std::cerr << "\n";
  return ReportCapture(request, summary);
}

void AddCaptureCommand(CLI::App& app) {
  auto request = std::make_shared<CaptureRequest>();
  CLI::App* capture = app.add_subcommand("capture", "Record a session with a rig (Ctrl-C stops cleanly)");
  capture->add_option("--rig", request->rig_path, "Rig file (config/rigs/*.yaml)")->required();
  capture->add_option("--out", request->out_dir, "New session folder")->required();
  capture->add_option("--duration", request->duration_minutes, "Stop after this many (clock) minutes");
  capture->add_option("--speedup", request->speedup, "Simulated clock speed-up (simulated rigs)");
  capture->add_flag("!--no-progress", request->progress, "No live progress line");
  capture->callback([request]() {
    const int code = RunCapture(*request);
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace relume::app
