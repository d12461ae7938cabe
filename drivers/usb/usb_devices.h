// USB devices of the rig seen through libusb-1.0: enumeration, recognition of known devices
// by vendor/product id, a clear message when a device is present but cannot be opened, and
// arrival/removal events (libusb hotplug where the platform has it, else polling).
//
// Conventions:
//  - Ids are the USB vendor/product ids (VID/PID) the devices report; a table entry without
//    a product id matches every product of that vendor (DSLR makers ship many PIDs).
//  - Bus numbers and addresses are libusb's (the /dev/bus/usb/BBB/DDD node); the address
//    changes on every re-plug, the port path (e.g. "1-2.3") does not.
//  - DeviceInfo from ListUsbDevices: backend "usb", id "VVVV:PPPP@<bus>-<port path>" (hex
//    ids), details: vendor, product, bus, address, openable and, when not, the problem.
//    These are for `relume devices` to show; the device itself is opened by the backend
//    named in details["backend"] (gphoto2 for DSLRs, openni2 for depth sensors).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/time.h"
#include "drivers/device_info.h"

namespace relume::drivers::usb {

struct KnownUsbDevice {
  std::uint16_t vendor_id = 0;
  std::optional<std::uint16_t> product_id;  // nullopt: any product of the vendor
  std::string name;                         // "Canon DSLR", "Microsoft Kinect (Xbox 360)"
  DeviceKind kind = DeviceKind::kStillCamera;
  std::string backend;  // relume backend that opens it: "gphoto2", "openni2"
};

// The rig's known devices (Canon 04a9, Nikon 04b0, Sony 054c DSLRs; PrimeSense 1d27,
// Microsoft Kinect 045e:02ae, Intel RealSense 8086 depth cameras).
const std::vector<KnownUsbDevice>& KnownUsbDevices();
// The most specific entry (vendor + product before vendor only), or nullopt.
std::optional<KnownUsbDevice> RecogniseUsbDevice(std::uint16_t vendor_id, std::uint16_t product_id);

struct UsbDeviceEntry {
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
  int bus = 0;
  int address = 0;
  std::string port_path;  // "1-2.3"; empty when libusb cannot tell
  std::optional<KnownUsbDevice> known;
  bool checked_open = false;  // an open was tried (known devices, when try_open)
  bool openable = false;
  std::string open_problem;  // what is wrong and what to do, when not openable
};

struct UsbEnumerateOptions {
  bool include_unknown = false;  // also list devices the table does not know
  bool try_open = true;          // open known devices to check permissions and claims
  bool IsValid(std::string* why) const;
};

// Throws IoError when libusb cannot be initialised (no usbfs, no permission on /dev/bus/usb).
std::vector<UsbDeviceEntry> EnumerateUsb(const UsbEnumerateOptions& options = {});
std::vector<DeviceInfo> ListUsbDevices(const UsbEnumerateOptions& options = {});

// What to tell a user when libusb_open / libusb_claim_interface failed with `libusb_error`
// (a LIBUSB_ERROR_* value) on the device at bus/address.
std::string DescribeOpenFailure(int libusb_error, std::uint16_t vendor_id, std::uint16_t product_id, int bus,
                                int address);

struct UsbHotplugEvent {
  enum class Change { kArrived, kLeft };
  UtcTime time;
  Change change = Change::kArrived;
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
  int bus = 0;
  int address = 0;
  std::string known_name;  // empty for devices the table does not know
};
const char* ToString(UsbHotplugEvent::Change change);

struct UsbWatcherOptions {
  bool force_polling = false;  // poll even where libusb has hotplug
  Nanoseconds poll_interval = std::chrono::milliseconds(500);
  bool only_known = false;      // report only devices in the table
  bool report_present = false;  // report devices already present as arrivals at start
  bool IsValid(std::string* why) const;
};

// Reports arrivals and removals to `callback` from its own thread until destroyed.
// Callbacks must be quick and must not destroy the watcher.
class UsbWatcher {
 public:
  using Callback = std::function<void(const UsbHotplugEvent&)>;
  UsbWatcher(Callback callback, UsbWatcherOptions options = {});
  ~UsbWatcher();
  UsbWatcher(const UsbWatcher&) = delete;
  UsbWatcher& operator=(const UsbWatcher&) = delete;
  // True when libusb hotplug callbacks are used, false when polling.
  bool using_hotplug() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace relume::drivers::usb
