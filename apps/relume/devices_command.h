// `relume devices`: every device each compiled-in backend sees, with what it can do, and the
// USB devices relume recognises. `relume devices --check ID` opens one device, takes one frame
// (one depth + colour pair for an RGB-D sensor) and reports how long each step took.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace relume::app {

struct DevicesRequest {
  std::string rig_path;                       // the rig's simulated devices (sim backend)
  std::string check_id;                       // "backend:id" or a bare id; empty = list only
  bool open = true;                           // open each listed device to read its capabilities
  std::vector<std::string> gphoto2_cameras;   // MODEL@PORT, for ports libgphoto2 cannot autodetect
  bool aravis_fake = false;                   // Aravis's in-process fake camera
  bool gige_discovery = true;                 // Aravis GigE broadcast discovery
  std::vector<std::string> aravis_addresses;  // GigE cameras probed by unicast
  std::vector<std::string> skip_backends;     // backends not to ask ("usb", "aravis", ...)
  double frame_timeout_s = 10.0;              // --check: longest wait for the frame
};

// Returns the exit code (0). Device errors during --check are thrown (DeviceError) with what
// is wrong and what to do.
int RunDevices(const DevicesRequest& request, std::ostream& out);
void AddDevicesCommand(CLI::App& app);

}  // namespace relume::app
