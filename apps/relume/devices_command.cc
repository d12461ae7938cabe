#include "apps/relume/devices_command.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "apps/relume/device_backends.h"
#include "core/error.h"
#include "drivers/device_error.h"
#include "rig/rig_config.h"

namespace relume::app {

namespace {

using Seconds = std::chrono::duration<double>;

std::string FormatSeconds(double t) {
  char text[48];
  if (!std::isfinite(t)) return "?";
  if (t >= 1.0 || t <= 0.0) {
    std::snprintf(text, sizeof(text), "%g s", t);
  } else if (t < 1e-4) {
    std::snprintf(text, sizeof(text), "%.3g us", t * 1e6);
  } else if (const double inverse = 1.0 / t; std::abs(inverse - std::round(inverse)) < 0.02 * inverse) {
    std::snprintf(text, sizeof(text), "1/%.0f s", std::round(inverse));
  } else {
    std::snprintf(text, sizeof(text), "%.3g s", t);
  }
  return text;
}

std::string Range(const std::vector<double>& values, const std::string& prefix, const std::string& unit) {
  if (values.empty()) return "fixed";
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  std::ostringstream s;
  s << prefix << *lo << unit << " .. " << prefix << *hi << unit << " (" << values.size() << " values)";
  return s.str();
}

std::string Milliseconds(Seconds d) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f ms", d.count() * 1e3);
  return text;
}

void PrintStillCapabilities(const drivers::ExposureCapabilities& c, std::ostream& out) {
  out << "    exposure: " << drivers::ToString(c.control);
  switch (c.control) {
    case drivers::ExposureControl::kShutterList:
      if (c.shutter_speeds_s.empty()) {
        out << ", no shutter speeds offered";
      } else {
        out << ", " << c.shutter_speeds_s.size() << " speeds " << FormatSeconds(c.shutter_speeds_s.front()) << " .. "
            << FormatSeconds(c.shutter_speeds_s.back());
      }
      break;
    case drivers::ExposureControl::kContinuous:
      out << " " << FormatSeconds(c.min_exposure_time_s) << " .. " << FormatSeconds(c.max_exposure_time_s);
      break;
    case drivers::ExposureControl::kEvOnly: out << ", EV compensation " << Range(c.ev_steps, "", " EV"); break;
  }
  out << "\n    aperture: " << Range(c.apertures_f, "f/", "") << "\n    ISO: " << Range(c.iso_values, "", "")
      << "\n    gain: ";
  if (c.max_gain_db > c.min_gain_db) {
    out << c.min_gain_db << " .. " << c.max_gain_db << " dB\n";
  } else {
    out << "fixed\n";
  }
}

void PrintDevice(const drivers::DeviceRegistry& registry, const drivers::DeviceInfo& info, bool open,
                 std::ostream& out) {
  out << "  " << info.FullId() << "  " << drivers::ToString(info.kind);
  if (!info.model.empty()) out << "  model \"" << info.model << "\"";
  if (!info.serial.empty()) out << "  serial " << info.serial;
  if (!info.address.empty()) out << "  address " << info.address;
  out << "\n";
  for (const auto& [key, value] : info.details) out << "    " << key << ": " << value << "\n";
  if (!open) return;
  try {
    if (info.kind == drivers::DeviceKind::kStillCamera) {
      PrintStillCapabilities(registry.OpenStillCamera(info)->capabilities(), out);
    } else {
      const std::vector<drivers::RgbdStreamConfig> configs = registry.OpenRgbdSensor(info)->SupportedConfigs();
      out << "    streams: " << configs.size() << "\n";
      for (const auto& c : configs) out << "      " << c.Describe() << "\n";
    }
  } catch (const Error& e) {
    out << "    not opened: " << e.what() << "\n";
  }
}

DeviceBackendOptions OptionsFor(const DevicesRequest& request, std::shared_ptr<rig::RigConfig>* rig) {
  DeviceBackendOptions options;
  if (!request.rig_path.empty()) *rig = std::make_shared<rig::RigConfig>(rig::LoadRigConfig(request.rig_path));
  if (*rig && !(*rig)->devices.empty()) {
    options.sim_devices = (*rig)->devices;
    options.sim_truth = (*rig)->world;
    options.sim_clock = std::make_shared<ManualClock>((*rig)->clock_start, "simulated, event-driven");
  }
  options.gphoto2_cameras = request.gphoto2_cameras;
  // A camera on a port libgphoto2 cannot autodetect is checked by naming it.
  const std::string gphoto2_prefix = "gphoto2:";
  if (request.check_id.rfind(gphoto2_prefix, 0) == 0) {
    const std::string camera = request.check_id.substr(gphoto2_prefix.size());
    if (camera.find("@usb:") == std::string::npos) options.gphoto2_cameras.push_back(camera);
  }
  options.aravis_fake = request.aravis_fake;
  options.aravis_gige_discovery = request.gige_discovery;
  options.aravis_addresses = request.aravis_addresses;
  const auto skipped = [&](const char* name) {
    return std::find(request.skip_backends.begin(), request.skip_backends.end(), name) != request.skip_backends.end();
  };
  options.gphoto2 = !skipped("gphoto2");
  options.openni2 = !skipped("openni2");
  options.aravis = !skipped("aravis");
  options.usb = !skipped("usb");
  return options;
}

void ListDevices(const drivers::DeviceRegistry& registry, const DevicesRequest& request,
                 const DeviceBackendOptions& options, const std::vector<std::string>& problems, std::ostream& out) {
  if (!options.sim_truth) out << "sim: no simulated devices (--rig FILE lists a rig's simulated devices)\n";
  for (const auto& backend : registry.backends()) {
    std::vector<drivers::DeviceInfo> devices;
    try {
      devices = backend->Enumerate();
    } catch (const Error& e) {
      out << backend->name() << ": could not list devices: " << e.what() << "\n";
      continue;
    }
    out << backend->name() << ": " << devices.size() << (devices.size() == 1 ? " device\n" : " devices\n");
    for (const auto& info : devices) PrintDevice(registry, info, request.open, out);
  }
  for (const std::string& problem : problems) out << problem << "\n";
  if (options.usb && UsbListingCompiled()) {
    try {
      const std::vector<drivers::DeviceInfo> usb = ListKnownUsbDevices();
      out << "usb (known devices, listing only): " << usb.size() << (usb.size() == 1 ? " device\n" : " devices\n");
      for (const auto& info : usb) PrintDevice(registry, info, false, out);
    } catch (const Error& e) {
      out << "usb: could not list devices: " << e.what() << "\n";
    }
  }
  for (const std::string& left_out : LeftOutBackends()) out << "left out of this build: " << left_out << "\n";
}

// Finds the device; "backend:id" asks only that backend (so a check does not wait for every
// backend's discovery).
drivers::DeviceInfo FindDevice(const drivers::DeviceRegistry& registry, const std::string& wanted) {
  const std::size_t colon = wanted.find(':');
  const std::string prefix = colon == std::string::npos ? "" : wanted.substr(0, colon);
  if (prefix == "usb") {
    throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, wanted,
                               "USB entries are listed only; check the device through the backend `relume devices` "
                               "names for it (gphoto2 for DSLRs, openni2 for depth sensors)");
  }
  for (const std::string& left_out : LeftOutBackends()) {
    if (!prefix.empty() && left_out.rfind(prefix + " ", 0) == 0) {
      throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, wanted,
                                 "backend '" + prefix + "' is not part of this build: " + left_out);
    }
  }
  for (const auto& backend : registry.backends()) {
    if (backend->name() != prefix) continue;
    const std::string id = wanted.substr(colon + 1);
    const std::vector<drivers::DeviceInfo> devices = backend->Enumerate();
    std::string seen;
    for (const auto& info : devices) {
      if (info.id == id) return info;
      seen += (seen.empty() ? "" : ", ") + info.FullId();
    }
    // The library's own reason (claimed by another program, no permission, ...), when it gives one.
    std::string reason;
    if (prefix == "gphoto2" || prefix == "openni2") {
      drivers::DeviceInfo guess;
      guess.backend = prefix;
      guess.id = id;
      try {
        if (prefix == "openni2") {
          guess.kind = drivers::DeviceKind::kRgbdSensor;
          backend->OpenRgbdSensor(guess);
        } else {
          backend->OpenStillCamera(guess);
        }
      } catch (const Error& e) {
        reason = std::string(" (opening it: ") + e.what() + ")";
      }
    }
    throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, wanted,
                               "not present" + reason + "; " + prefix + " sees " +
                                   (seen.empty() ? std::string("no devices") : seen) +
                                   ". Check that it is plugged in, powered and not held by another program; "
                                   "`relume devices` lists what every backend sees");
  }
  if (!prefix.empty() && prefix == "sim") {
    throw drivers::DeviceError(drivers::DeviceErrorKind::kNotFound, wanted,
                               "the sim backend needs the rig that defines its devices: add --rig FILE");
  }
  return registry.Find(wanted);
}

void CheckDevice(const drivers::DeviceRegistry& registry, const DevicesRequest& request, std::ostream& out) {
  using Clock = std::chrono::steady_clock;
  const drivers::DeviceInfo info = FindDevice(registry, request.check_id);
  out << "checking " << info.FullId() << " (" << drivers::ToString(info.kind) << ", model \"" << info.model << "\")\n";
  auto t0 = Clock::now();
  if (info.kind == drivers::DeviceKind::kStillCamera) {
    std::unique_ptr<drivers::StillCamera> camera = registry.OpenStillCamera(info);
    out << "  open: " << Milliseconds(Clock::now() - t0) << "\n";
    t0 = Clock::now();
    const drivers::StillFrame frame = camera->Capture();
    out << "  capture + download: " << Milliseconds(Clock::now() - t0) << "\n";
    out << "  frame: " << frame.image.width() << "x" << frame.image.height() << " " << ToString(frame.image.layout)
        << " " << frame.image.bits_per_sample << "-bit";
    if (!frame.original_file.empty()) {
      out << ", camera file " << frame.original_format << " " << frame.original_file.size() << " bytes";
    }
    out << ", exposure " << FormatSeconds(frame.exposure.exposure_time_s);
    if (std::isfinite(frame.exposure.aperture_f)) out << " f/" << frame.exposure.aperture_f;
    if (std::isfinite(frame.exposure.iso)) out << " ISO " << frame.exposure.iso;
    if (frame.exposure.ev_compensation != 0.0) out << " EV " << frame.exposure.ev_compensation;
    out << ", sequence " << frame.timing.sequence << "\n";
    t0 = Clock::now();
    camera.reset();
    out << "  close: " << Milliseconds(Clock::now() - t0) << "\n";
  } else {
    std::unique_ptr<drivers::RgbdSensor> sensor = registry.OpenRgbdSensor(info);
    out << "  open: " << Milliseconds(Clock::now() - t0) << "\n";
    const std::vector<drivers::RgbdStreamConfig> configs = sensor->SupportedConfigs();
    if (configs.empty()) {
      throw drivers::DeviceError(drivers::DeviceErrorKind::kUnsupportedSetting, info.FullId(),
                                 "offers no depth + colour stream relume can read");
    }
    t0 = Clock::now();
    sensor->Start(configs.front());
    out << "  start (" << configs.front().Describe() << "): " << Milliseconds(Clock::now() - t0) << "\n";
    t0 = Clock::now();
    const drivers::RgbdFrame frame = sensor->WaitForFrame(
        std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(request.frame_timeout_s)));
    out << "  first frame: " << Milliseconds(Clock::now() - t0) << "\n";
    int valid = 0;
    for (int y = 0; y < frame.depth_m.rows; ++y) {
      for (int x = 0; x < frame.depth_m.cols; ++x) valid += std::isfinite(frame.depth_m.at<float>(y, x)) ? 1 : 0;
    }
    out << "  frame: depth " << frame.depth_m.cols << "x" << frame.depth_m.rows << " ("
        << (frame.depth_m.total() ? 100.0 * valid / static_cast<double>(frame.depth_m.total()) : 0.0)
        << " % measured), colour " << frame.color.width() << "x" << frame.color.height() << ", sequence "
        << frame.depth_timing.sequence << "\n";
    t0 = Clock::now();
    sensor->Stop();
    out << "  stop: " << Milliseconds(Clock::now() - t0) << "\n";
    t0 = Clock::now();
    sensor.reset();
    out << "  close: " << Milliseconds(Clock::now() - t0) << "\n";
  }
  out << "OK\n";
}

}  // namespace

int RunDevices(const DevicesRequest& request, std::ostream& out) {
  std::shared_ptr<rig::RigConfig> rig;
  const DeviceBackendOptions options = OptionsFor(request, &rig);
  std::vector<std::string> problems;
  const std::shared_ptr<drivers::DeviceRegistry> registry = BuildDeviceRegistry(options, &problems);
  if (request.check_id.empty()) {
    ListDevices(*registry, request, options, problems, out);
  } else {
    CheckDevice(*registry, request, out);
  }
  return 0;
}

void AddDevicesCommand(CLI::App& app) {
  auto request = std::make_shared<DevicesRequest>();
  CLI::App* devices = app.add_subcommand("devices", "List the devices every backend sees; --check ID tests one");
  devices->add_option("--rig", request->rig_path, "Rig file whose simulated devices the sim backend lists");
  devices->add_option("--check", request->check_id,
                      "Open this device (backend:id, as listed), take one frame and report the timings");
  devices->add_flag("!--no-open", request->open, "List without opening devices (no capabilities)");
  devices->add_option("--gphoto2", request->gphoto2_cameras,
                      "A camera libgphoto2 cannot autodetect, as MODEL@PORT (PTP/IP, disk); repeatable");
  devices->add_flag("--aravis-fake", request->aravis_fake, "Include Aravis's in-process fake camera");
  devices->add_flag("!--no-gige-discovery", request->gige_discovery,
                    "No GigE Vision broadcast discovery (probe --aravis-address only)");
  devices->add_option("--aravis-address", request->aravis_addresses, "GigE camera address probed by unicast");
  devices->add_option("--skip", request->skip_backends, "Backends not to ask: gphoto2, openni2, aravis, usb");
  devices->add_option("--timeout", request->frame_timeout_s, "--check: seconds to wait for the frame")
      ->check(CLI::PositiveNumber);
  devices->callback([request]() { RunDevices(*request, std::cout); });
}

}  // namespace relume::app
