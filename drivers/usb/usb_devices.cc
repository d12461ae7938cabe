#include "drivers/usb/usb_devices.h"

#include <libusb.h>

#include <atomic>
#include <cstdio>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <tuple>

#include "core/error.h"

namespace relume::drivers::usb {
namespace {

std::string Hex4(std::uint16_t v) {
  char text[8];
  std::snprintf(text, sizeof(text), "%04x", v);
  return text;
}

std::string DevNode(int bus, int address) {
  char text[32];
  std::snprintf(text, sizeof(text), "/dev/bus/usb/%03d/%03d", bus, address);
  return text;
}

// One libusb context, released on scope exit.
class Context {
 public:
  Context() {
    const int rc = libusb_init(&ctx_);
    if (rc != LIBUSB_SUCCESS) {
      throw IoError("/dev/bus/usb", std::string("libusb cannot start: ") + libusb_error_name(rc) +
                                        " (is usbfs mounted and readable by this user?)");
    }
  }
  ~Context() { libusb_exit(ctx_); }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  libusb_context* get() const { return ctx_; }

 private:
  libusb_context* ctx_ = nullptr;
};

std::string PortPath(libusb_device* device) {
  std::uint8_t ports[8];
  const int n = libusb_get_port_numbers(device, ports, 8);
  if (n <= 0) return "";
  std::string path = std::to_string(libusb_get_bus_number(device)) + "-";
  for (int i = 0; i < n; ++i) {
    if (i > 0) path += '.';
    path += std::to_string(ports[i]);
  }
  return path;
}

// Opens the device and tries to claim its first interface, as a backend would.
void CheckOpen(libusb_device* device, UsbDeviceEntry* entry) {
  entry->checked_open = true;
  libusb_device_handle* handle = nullptr;
  int rc = libusb_open(device, &handle);
  if (rc == LIBUSB_SUCCESS) {
    if (libusb_kernel_driver_active(handle, 0) == 1) {
      rc = LIBUSB_ERROR_BUSY;  // a kernel driver holds interface 0
    } else {
      rc = libusb_claim_interface(handle, 0);
      if (rc == LIBUSB_SUCCESS) libusb_release_interface(handle, 0);
      if (rc == LIBUSB_ERROR_NOT_FOUND) rc = LIBUSB_SUCCESS;  // no interface 0 to claim: opening is what counts
    }
    libusb_close(handle);
  }
  entry->openable = rc == LIBUSB_SUCCESS;
  if (!entry->openable) {
    entry->open_problem = DescribeOpenFailure(rc, entry->vendor_id, entry->product_id, entry->bus, entry->address);
  }
}

UsbDeviceEntry Describe(libusb_device* device) {
  UsbDeviceEntry entry;
  libusb_device_descriptor descriptor{};
  if (libusb_get_device_descriptor(device, &descriptor) == LIBUSB_SUCCESS) {
    entry.vendor_id = descriptor.idVendor;
    entry.product_id = descriptor.idProduct;
  }
  entry.bus = libusb_get_bus_number(device);
  entry.address = libusb_get_device_address(device);
  entry.port_path = PortPath(device);
  entry.known = RecogniseUsbDevice(entry.vendor_id, entry.product_id);
  return entry;
}

UsbHotplugEvent MakeEvent(const UsbDeviceEntry& entry, UsbHotplugEvent::Change change) {
  UsbHotplugEvent event;
  event.time = UtcNow();
  event.change = change;
  event.vendor_id = entry.vendor_id;
  event.product_id = entry.product_id;
  event.bus = entry.bus;
  event.address = entry.address;
  if (entry.known) event.known_name = entry.known->name;
  return event;
}

}  // namespace

const std::vector<KnownUsbDevice>& KnownUsbDevices() {
  static const std::vector<KnownUsbDevice> table = {
      {0x04a9, std::nullopt, "Canon DSLR", DeviceKind::kStillCamera, "gphoto2"},
      {0x04b0, std::nullopt, "Nikon DSLR", DeviceKind::kStillCamera, "gphoto2"},
      {0x054c, std::nullopt, "Sony camera", DeviceKind::kStillCamera, "gphoto2"},
      {0x1d27, std::nullopt, "PrimeSense depth sensor", DeviceKind::kRgbdSensor, "openni2"},
      {0x045e, 0x02ae, "Microsoft Kinect (Xbox 360) camera", DeviceKind::kRgbdSensor, "openni2"},
      {0x8086, std::nullopt, "Intel RealSense depth camera", DeviceKind::kRgbdSensor, "openni2"},
  };
  return table;
}

std::optional<KnownUsbDevice> RecogniseUsbDevice(std::uint16_t vendor_id, std::uint16_t product_id) {
  const KnownUsbDevice* vendor_match = nullptr;
  for (const KnownUsbDevice& known : KnownUsbDevices()) {
    if (known.vendor_id != vendor_id) continue;
    if (known.product_id == product_id) return known;
    if (!known.product_id && vendor_match == nullptr) vendor_match = &known;
  }
  if (vendor_match != nullptr) return *vendor_match;
  return std::nullopt;
}

std::string DescribeOpenFailure(int libusb_error, std::uint16_t vendor_id, std::uint16_t product_id, int bus,
                                int address) {
  const std::string device = Hex4(vendor_id) + ":" + Hex4(product_id) + " at " + DevNode(bus, address);
  switch (libusb_error) {
    case LIBUSB_ERROR_ACCESS:
      return device + ": permission denied. Add a udev rule, e.g. /etc/udev/rules.d/70-relume.rules with " +
             "SUBSYSTEM==\"usb\", ATTR{idVendor}==\"" + Hex4(vendor_id) +
             "\", MODE=\"0660\", GROUP=\"plugdev\"; run `udevadm control --reload && udevadm trigger`, " +
             "add your user to the plugdev group (`usermod -aG plugdev $USER`, then log in again) and re-plug";
    case LIBUSB_ERROR_BUSY:
      return device + ": busy, claimed by another process or a kernel driver. On desktops GVFS mounts cameras " +
             "(gvfs-gphoto2-volume-monitor, gvfsd-gphoto2): unmount it (`gio mount -u gphoto2://...`) or stop " +
             "those processes (`systemctl --user stop gvfs-gphoto2-volume-monitor`), and close other camera " +
             "programs; `lsof " + DevNode(bus, address) + "` shows who holds it";
    case LIBUSB_ERROR_NO_DEVICE:
      return device + ": the device went away while being opened (unplugged, reset, or its node is missing)";
    case LIBUSB_ERROR_NOT_SUPPORTED:
      return device + ": libusb cannot open this device on this platform (no usbfs access)";
    default: return device + ": cannot be opened: " + libusb_error_name(libusb_error);
  }
}

bool UsbEnumerateOptions::IsValid(std::string* /*why*/) const {
  return true;
}

std::vector<UsbDeviceEntry> EnumerateUsb(const UsbEnumerateOptions& options) {
  ThrowIfInvalid(options, "UsbEnumerateOptions");
  Context context;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(context.get(), &list);
  if (n < 0) {
    throw IoError("/dev/bus/usb", std::string("libusb cannot list devices: ") + libusb_error_name(static_cast<int>(n)));
  }
  std::vector<UsbDeviceEntry> out;
  for (ssize_t i = 0; i < n; ++i) {
    UsbDeviceEntry entry = Describe(list[i]);
    if (!entry.known && !options.include_unknown) continue;
    if (entry.known && options.try_open) CheckOpen(list[i], &entry);
    out.push_back(std::move(entry));
  }
  libusb_free_device_list(list, 1);
  return out;
}

std::vector<DeviceInfo> ListUsbDevices(const UsbEnumerateOptions& options) {
  std::vector<DeviceInfo> out;
  for (const UsbDeviceEntry& e : EnumerateUsb(options)) {
    DeviceInfo info;
    info.backend = "usb";
    const std::string location =
        e.port_path.empty() ? std::to_string(e.bus) + "." + std::to_string(e.address) : e.port_path;
    info.id = Hex4(e.vendor_id) + ":" + Hex4(e.product_id) + "@" + location;
    info.kind = e.known ? e.known->kind : DeviceKind::kStillCamera;
    info.model = e.known ? e.known->name : "unknown USB device";
    info.address = DevNode(e.bus, e.address);
    info.details["vendor_id"] = Hex4(e.vendor_id);
    info.details["product_id"] = Hex4(e.product_id);
    info.details["bus"] = std::to_string(e.bus);
    info.details["address"] = std::to_string(e.address);
    if (e.known) info.details["backend"] = e.known->backend;
    if (e.checked_open) info.details["openable"] = e.openable ? "yes" : "no";
    if (!e.open_problem.empty()) info.details["problem"] = e.open_problem;
    out.push_back(std::move(info));
  }
  return out;
}

const char* ToString(UsbHotplugEvent::Change change) {
  return change == UsbHotplugEvent::Change::kArrived ? "arrived" : "left";
}

bool UsbWatcherOptions::IsValid(std::string* why) const {
  if (poll_interval < std::chrono::milliseconds(10) || poll_interval > std::chrono::minutes(10)) {
    if (why) *why = "poll_interval must be within 10 ms .. 10 min";
    return false;
  }
  return true;
}

struct UsbWatcher::Impl {
  Callback callback;
  UsbWatcherOptions options;
  Context context;
  bool hotplug = false;
  libusb_hotplug_callback_handle handle = 0;
  std::atomic<bool> stop{false};
  std::thread thread;
  // Polling: what the last enumeration saw, keyed by (bus, address, vid, pid).
  std::map<std::tuple<int, int, int, int>, UsbDeviceEntry> present;

  void Emit(const UsbDeviceEntry& entry, UsbHotplugEvent::Change change) {
    if (options.only_known && !entry.known) return;
    callback(MakeEvent(entry, change));
  }

  static int OnHotplug(libusb_context* /*ctx*/, libusb_device* device, libusb_hotplug_event event, void* self) {
    auto* impl = static_cast<Impl*>(self);
    impl->Emit(Describe(device), event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED ? UsbHotplugEvent::Change::kArrived
                                                                              : UsbHotplugEvent::Change::kLeft);
    return 0;  // stay registered
  }

  std::map<std::tuple<int, int, int, int>, UsbDeviceEntry> Scan() {
    std::map<std::tuple<int, int, int, int>, UsbDeviceEntry> now;
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(context.get(), &list);
    for (ssize_t i = 0; i < n; ++i) {
      UsbDeviceEntry e = Describe(list[i]);
      now.emplace(std::make_tuple(e.bus, e.address, int{e.vendor_id}, int{e.product_id}), e);
    }
    if (n >= 0) libusb_free_device_list(list, 1);
    return now;
  }

  void Poll() {
    auto now = Scan();
    for (const auto& [key, entry] : present) {
      if (!now.count(key)) Emit(entry, UsbHotplugEvent::Change::kLeft);
    }
    for (const auto& [key, entry] : now) {
      if (!present.count(key)) Emit(entry, UsbHotplugEvent::Change::kArrived);
    }
    present = std::move(now);
  }

  void Run() {
    while (!stop.load()) {
      if (hotplug) {
        timeval tv{0, 100000};
        libusb_handle_events_timeout_completed(context.get(), &tv, nullptr);
      } else {
        const MonotonicTime next = MonotonicNow() + options.poll_interval;
        while (!stop.load() && MonotonicNow() < next) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        if (!stop.load()) Poll();
      }
    }
  }
};

UsbWatcher::UsbWatcher(Callback callback, UsbWatcherOptions options) : impl_(std::make_unique<Impl>()) {
  ThrowIfInvalid(options, "UsbWatcherOptions");
  RELUME_CHECK(callback != nullptr);
  impl_->callback = std::move(callback);
  impl_->options = options;
  impl_->hotplug = !options.force_polling && libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0;
  if (impl_->hotplug) {
    const int flags = options.report_present ? LIBUSB_HOTPLUG_ENUMERATE : 0;
    const int rc = libusb_hotplug_register_callback(
        impl_->context.get(), LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT, flags,
        LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, &Impl::OnHotplug, impl_.get(),
        &impl_->handle);
    if (rc != LIBUSB_SUCCESS) impl_->hotplug = false;  // fall back to polling
  }
  if (!impl_->hotplug) {
    impl_->present = impl_->Scan();
    if (options.report_present) {
      for (const auto& [key, entry] : impl_->present) impl_->Emit(entry, UsbHotplugEvent::Change::kArrived);
    }
  }
  impl_->thread = std::thread([impl = impl_.get()] { impl->Run(); });
}

UsbWatcher::~UsbWatcher() {
  impl_->stop.store(true);
  if (impl_->hotplug) libusb_hotplug_deregister_callback(impl_->context.get(), impl_->handle);  // wakes the loop
  impl_->thread.join();
}

bool UsbWatcher::using_hotplug() const {
  return impl_->hotplug;
}

}  // namespace relume::drivers::usb
