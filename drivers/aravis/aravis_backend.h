// The "aravis" backend: GenICam cameras (GigE Vision, USB3 Vision, Aravis's in-process fake)
// enumerated and opened through Aravis 0.8.
//
// Conventions:
//  - DeviceInfo::id is Aravis's device id ("<vendor>-<model>-<serial>" for GigE and USB3
//    cameras, "Fake_1" for the in-process fake); details hold vendor, protocol, physical id
//    and "aravis_device" (what is handed to arv_camera_new: the id, or the address of a
//    camera found by a unicast probe).
//  - Aravis's interface switches and device list are process-wide; the backend serialises
//    its calls to them and sets the switches from its options on every enumeration.
//  - GigE discovery broadcasts on every network interface. Where that is unwanted (tests,
//    routed networks), turn it off and list the cameras' addresses in gige_addresses: each is
//    probed by unicast only (through Aravis's GigE interface, arv_camera_new(address)).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "drivers/aravis/aravis_camera.h"
#include "drivers/backend.h"

namespace relume::drivers::aravis {

struct AravisBackendOptions {
  bool gige_discovery = true;               // broadcast discovery on all interfaces
  bool usb3 = true;                         // USB3 Vision cameras (libusb)
  bool fake = false;                        // Aravis's in-process fake camera "Fake_1"
  std::vector<std::string> gige_addresses;  // cameras probed by unicast, e.g. "192.168.1.20"
  AravisCameraOptions camera;               // used by every camera this backend opens
  bool IsValid(std::string* why) const;
};

class AravisBackend : public Backend {
 public:
  explicit AravisBackend(AravisBackendOptions options = {});
  std::string name() const override { return "aravis"; }
  std::vector<DeviceInfo> Enumerate() override;
  // Finds the device by id, then serial, then address among what Enumerate() sees.
  std::unique_ptr<StillCamera> OpenStillCamera(const DeviceInfo& info) override;
  std::unique_ptr<RgbdSensor> OpenRgbdSensor(const DeviceInfo& info) override;
  // The same as OpenStillCamera, with the streaming interface.
  std::unique_ptr<AravisCamera> OpenCamera(const DeviceInfo& info);

 private:
  AravisBackendOptions options_;
};

// What Aravis sees, as DeviceInfo (for `relume devices`).
std::vector<DeviceInfo> ListAravisDevices(const AravisBackendOptions& options = {});

}  // namespace relume::drivers::aravis
