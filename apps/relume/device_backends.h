// The device backends this build has, wired into one drivers::DeviceRegistry for the CLI
// (`relume devices`, `relume capture` with real devices). A backend whose library was missing
// at build time is not compiled (its CMake target does not exist) and is named in
// LeftOutBackends() with the package that brings it; nothing stands in for it.
//
// Which backends are added, and how they look for devices, comes from DeviceBackendOptions:
// command-line flags for `relume devices`, the rig file's devices for `relume capture`.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/clock.h"
#include "drivers/backend.h"
#include "sim/devices/sim_backend.h"
#include "sim/truth.h"

namespace relume::app {

struct DeviceBackendOptions {
  // sim: the rig's simulated devices and the world they look at (none: sim lists nothing).
  std::vector<sim::SimDeviceSpec> sim_devices;
  std::shared_ptr<const sim::TruthSource> sim_truth;
  std::shared_ptr<Clock> sim_clock;

  bool gphoto2 = true;
  bool gphoto2_autodetect = true;
  // Cameras on ports libgphoto2 cannot autodetect, as "MODEL@PORT" (e.g.
  // "Nikon DSC D750@ptpip:192.168.1.1", "Relume Simulated DSLR@disk:/tmp/card").
  std::vector<std::string> gphoto2_cameras;

  bool openni2 = true;

  bool aravis = true;
  bool aravis_gige_discovery = true;  // broadcast discovery on every interface
  bool aravis_usb3 = true;
  bool aravis_fake = false;                   // Aravis's in-process fake camera "Fake_1" (tests, demos)
  std::vector<std::string> aravis_addresses;  // GigE cameras probed by unicast

  bool usb = true;  // the USB listing (known VID/PIDs); listing only, never opened as a device
};

// Compiled-in backends, by name, in the order they are listed.
std::vector<std::string> CompiledBackends();
// Backends left out of this build, each with what to install ("aravis: install libaravis-dev
// and rebuild").
std::vector<std::string> LeftOutBackends();

// Adds every compiled backend the options switch on. A backend whose library fails to start
// (OpenNI2 initialisation, say) is skipped and the reason appended to `problems`.
std::shared_ptr<drivers::DeviceRegistry> BuildDeviceRegistry(const DeviceBackendOptions& options,
                                                             std::vector<std::string>* problems);

// The USB devices libusb sees that relume knows (Canon, Nikon, Sony DSLRs; PrimeSense, Kinect,
// RealSense depth sensors), as DeviceInfo (backend "usb"). Empty when libusb is not part of
// the build; throws IoError when libusb cannot start.
bool UsbListingCompiled();
std::vector<drivers::DeviceInfo> ListKnownUsbDevices();

// Opens a still camera and sets the given configuration values on it, in order. Only gphoto2
// cameras take settings (rig files refuse them elsewhere). Throws drivers::DeviceError naming
// the setting when the camera has no such setting or does not offer the value.
std::unique_ptr<drivers::StillCamera> OpenStillCameraWithSettings(
    const drivers::DeviceRegistry& registry, const drivers::DeviceInfo& device,
    const std::vector<std::pair<std::string, std::string>>& settings);

// "MODEL@PORT" -> {model, port}; the last '@' splits (models may contain '@'; ports do not).
// Throws InvalidArgumentError naming the text when it has no '@' or an empty side.
std::pair<std::string, std::string> SplitModelAtPort(const std::string& model_at_port);

}  // namespace relume::app
