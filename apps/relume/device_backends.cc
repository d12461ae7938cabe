#include "apps/relume/device_backends.h"

#include "core/error.h"
#include "drivers/device_error.h"

#if RELUME_HAVE_GPHOTO2
#include "drivers/gphoto2/gphoto2_backend.h"
#endif
#if RELUME_HAVE_OPENNI2
#include "drivers/openni2/openni2_backend.h"
#endif
#if RELUME_HAVE_ARAVIS
#include "drivers/aravis/aravis_backend.h"
#endif
#if RELUME_HAVE_USB
#include "drivers/usb/usb_devices.h"
#endif

namespace relume::app {

std::vector<std::string> CompiledBackends() {
  std::vector<std::string> names = {"sim"};
#if RELUME_HAVE_GPHOTO2
  names.push_back("gphoto2");
#endif
#if RELUME_HAVE_OPENNI2
  names.push_back("openni2");
#endif
#if RELUME_HAVE_ARAVIS
  names.push_back("aravis");
#endif
  return names;
}

std::vector<std::string> LeftOutBackends() {
  std::vector<std::string> out;
#if !RELUME_HAVE_GPHOTO2
  out.push_back("gphoto2 (DSLRs): install libgphoto2-dev and rebuild");
#endif
#if !RELUME_HAVE_OPENNI2
  out.push_back("openni2 (RGB-D sensors): install libopenni2-dev and rebuild");
#endif
#if !RELUME_HAVE_ARAVIS
  out.push_back("aravis (GigE/USB3 Vision cameras): install libaravis-dev and rebuild");
#endif
#if !RELUME_HAVE_USB
  out.push_back("usb (USB listing): install libusb-1.0-0-dev and rebuild");
#endif
  return out;
}

std::unique_ptr<drivers::StillCamera> OpenStillCameraWithSettings(
    const drivers::DeviceRegistry& registry, const drivers::DeviceInfo& device,
    const std::vector<std::pair<std::string, std::string>>& settings) {
  std::unique_ptr<drivers::StillCamera> camera = registry.OpenStillCamera(device);
  if (settings.empty()) return camera;
#if RELUME_HAVE_GPHOTO2
  if (auto* gphoto2 = dynamic_cast<drivers::gphoto2::GPhoto2Camera*>(camera.get())) {
    for (const auto& [name, value] : settings) {
      try {
        gphoto2->SetConfigValue(name, value);
      } catch (const drivers::DeviceError& e) {
        std::string choices;
        try {
          for (const std::string& c : gphoto2->ConfigChoices(name)) choices += (choices.empty() ? "" : ", ") + c;
        } catch (const drivers::DeviceError&) {
        }
        throw drivers::DeviceError(e.kind(), device.FullId(),
                                   "setting " + name + " = \"" + value + "\" from the rig: " + e.what() +
                                       (choices.empty() ? "" : " (the camera offers: " + choices + ")"));
      }
    }
    return camera;
  }
#endif
  throw InvalidArgumentError(device.FullId() + ": camera settings are for gphoto2 cameras only");
}

std::pair<std::string, std::string> SplitModelAtPort(const std::string& text) {
  const std::size_t at = text.rfind('@');
  if (at == std::string::npos || at == 0 || at + 1 == text.size()) {
    throw InvalidArgumentError("'" + text +
                               "': name a gphoto2 camera as MODEL@PORT, e.g. \"Nikon DSC D750@ptpip:192.168.1.1\"");
  }
  return {text.substr(0, at), text.substr(at + 1)};
}

std::shared_ptr<drivers::DeviceRegistry> BuildDeviceRegistry(const DeviceBackendOptions& options,
                                                             std::vector<std::string>* problems) {
  auto registry = std::make_shared<drivers::DeviceRegistry>();
  auto note = [&](const std::string& backend, const std::string& why) {
    if (problems) problems->push_back(backend + ": " + why);
  };
  if (options.sim_truth && options.sim_clock) {
    registry->Add(std::make_shared<sim::SimBackend>(options.sim_devices, options.sim_truth, options.sim_clock));
  }
#if RELUME_HAVE_GPHOTO2
  if (options.gphoto2) {
    drivers::gphoto2::GPhoto2BackendOptions o;
    o.autodetect = options.gphoto2_autodetect;
    for (const std::string& camera : options.gphoto2_cameras) {
      const auto [model, port] = SplitModelAtPort(camera);
      o.configured.push_back({model, port});
    }
    ThrowIfInvalid(o, "gphoto2 options");
    registry->Add(std::make_shared<drivers::gphoto2::GPhoto2Backend>(o));
  }
#endif
#if RELUME_HAVE_OPENNI2
  if (options.openni2) {
    try {
      registry->Add(std::make_shared<drivers::openni2::OpenNI2Backend>());
    } catch (const Error& e) {
      note("openni2", std::string("OpenNI2 did not start: ") + e.what());
    }
  }
#endif
#if RELUME_HAVE_ARAVIS
  if (options.aravis) {
    drivers::aravis::AravisBackendOptions o;
    o.gige_discovery = options.aravis_gige_discovery;
    o.usb3 = options.aravis_usb3;
    o.fake = options.aravis_fake;
    o.gige_addresses = options.aravis_addresses;
    ThrowIfInvalid(o, "aravis options");
    registry->Add(std::make_shared<drivers::aravis::AravisBackend>(o));
  }
#endif
  return registry;
}

bool UsbListingCompiled() {
#if RELUME_HAVE_USB
  return true;
#else
  return false;
#endif
}

std::vector<drivers::DeviceInfo> ListKnownUsbDevices() {
#if RELUME_HAVE_USB
  return drivers::usb::ListUsbDevices();
#else
  return {};
#endif
}

}  // namespace relume::app
