#include "drivers/aravis/aravis_backend.h"

extern "C" {
#include <arv.h>
}

#include <mutex>

namespace relume::drivers::aravis {
namespace {

std::mutex& AravisSystemMutex() {
  static std::mutex mutex;
  return mutex;
}

std::string OrEmpty(const char* s) {
  return s != nullptr ? s : "";
}

void SetInterfaces(const AravisBackendOptions& options) {
  auto set = [](const char* id, bool on) { on ? arv_enable_interface(id) : arv_disable_interface(id); };
  set("Fake", options.fake);
  set("USB3Vision", options.usb3);
  set("GigEVision", options.gige_discovery);
}

// Aravis opens an address only through an enabled GigE interface. Opening an IP literal that
// is not in the discovery cache sends unicast packets to that address only (no broadcast),
// so the interface is switched on just for such opens and restored afterwards.
class GigEEnabledForUnicast {
 public:
  explicit GigEEnabledForUnicast(bool discovery_on) : discovery_on_(discovery_on) {
    arv_enable_interface("GigEVision");
  }
  ~GigEEnabledForUnicast() {
    if (!discovery_on_) arv_disable_interface("GigEVision");
  }

 private:
  bool discovery_on_;
};

// Opens a GigE camera at `address` (unicast only) to read what discovery would have said.
std::optional<DeviceInfo> ProbeAddress(const std::string& address, bool discovery_on) {
  GigEEnabledForUnicast gige(discovery_on);
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(address.c_str(), &error);
  if (camera == nullptr) {
    if (error != nullptr) g_error_free(error);
    return std::nullopt;
  }
  DeviceInfo info;
  info.backend = "aravis";
  info.kind = DeviceKind::kStillCamera;
  const std::string vendor = OrEmpty(arv_camera_get_vendor_name(camera, nullptr));
  const std::string model = OrEmpty(arv_camera_get_model_name(camera, nullptr));
  info.serial = OrEmpty(arv_camera_get_device_serial_number(camera, nullptr));
  info.id = vendor + "-" + model + "-" + info.serial;
  info.model = vendor.empty() ? model : vendor + " " + model;
  info.address = address;
  info.details["vendor"] = vendor;
  info.details["protocol"] = "GigEVision";
  info.details["found_by"] = "unicast probe";
  info.details["aravis_device"] = address;
  g_object_unref(camera);
  return info;
}

}  // namespace

bool AravisBackendOptions::IsValid(std::string* why) const {
  for (const std::string& a : gige_addresses) {
    if (a.empty()) {
      if (why) *why = "gige_addresses holds an empty address";
      return false;
    }
  }
  return camera.IsValid(why);
}

AravisBackend::AravisBackend(AravisBackendOptions options) : options_(std::move(options)) {
  ThrowIfInvalid(options_, "AravisBackendOptions");
}

std::vector<DeviceInfo> ListAravisDevices(const AravisBackendOptions& options) {
  ThrowIfInvalid(options, "AravisBackendOptions");
  std::lock_guard<std::mutex> lock(AravisSystemMutex());
  SetInterfaces(options);
  arv_update_device_list();
  std::vector<DeviceInfo> out;
  const unsigned n = arv_get_n_devices();
  for (unsigned i = 0; i < n; ++i) {
    DeviceInfo info;
    info.backend = "aravis";
    info.kind = DeviceKind::kStillCamera;
    info.id = OrEmpty(arv_get_device_id(i));
    const std::string vendor = OrEmpty(arv_get_device_vendor(i));
    const std::string model = OrEmpty(arv_get_device_model(i));
    info.model = vendor.empty() ? model : vendor + " " + model;
    info.serial = OrEmpty(arv_get_device_serial_nbr(i));
    info.address = OrEmpty(arv_get_device_address(i));
    info.details["vendor"] = vendor;
    info.details["protocol"] = OrEmpty(arv_get_device_protocol(i));
    info.details["physical_id"] = OrEmpty(arv_get_device_physical_id(i));
    info.details["found_by"] = "discovery";
    info.details["aravis_device"] = info.id;
    out.push_back(std::move(info));
  }
  for (const std::string& address : options.gige_addresses) {
    std::optional<DeviceInfo> probed = ProbeAddress(address, options.gige_discovery);
    if (!probed) continue;  // nothing answers there now
    bool known = false;
    for (const DeviceInfo& d : out) known = known || d.id == probed->id;
    if (!known) out.push_back(std::move(*probed));
  }
  return out;
}

std::vector<DeviceInfo> AravisBackend::Enumerate() {
  return ListAravisDevices(options_);
}

std::unique_ptr<AravisCamera> AravisBackend::OpenCamera(const DeviceInfo& wanted) {
  if (wanted.kind != DeviceKind::kStillCamera) {
    throw InvalidArgumentError(wanted.FullId() + ": the aravis backend opens still cameras only");
  }
  const std::vector<DeviceInfo> all = Enumerate();
  const DeviceInfo* found = nullptr;
  for (const DeviceInfo& d : all) {
    if (!found && !wanted.id.empty() && d.id == wanted.id) found = &d;
  }
  for (const DeviceInfo& d : all) {
    if (!found && !wanted.serial.empty() && d.serial == wanted.serial) found = &d;
  }
  for (const DeviceInfo& d : all) {
    if (!found && !wanted.address.empty() && d.address == wanted.address) found = &d;
  }
  if (found == nullptr) {
    std::string available;
    for (const DeviceInfo& d : all) available += (available.empty() ? "" : ", ") + d.FullId();
    throw DeviceError(DeviceErrorKind::kNotFound, wanted.FullId(),
                      "no Aravis camera with this id, serial or address; seen: " +
                          (available.empty() ? std::string("none") : available) +
                          " (GigE: same subnet, or list its address in gige_addresses; USB3: udev rule)");
  }
  std::lock_guard<std::mutex> lock(AravisSystemMutex());  // arv_camera_new reads the device list
  std::optional<GigEEnabledForUnicast> gige;
  if (found->details.at("found_by") == "unicast probe") gige.emplace(options_.gige_discovery);
  return std::make_unique<AravisCamera>(*found, found->details.at("aravis_device"), options_.camera);
}

std::unique_ptr<StillCamera> AravisBackend::OpenStillCamera(const DeviceInfo& info) {
  return OpenCamera(info);
}

std::unique_ptr<RgbdSensor> AravisBackend::OpenRgbdSensor(const DeviceInfo& info) {
  throw InvalidArgumentError(info.FullId() + ": the aravis backend has no RGB-D sensors");
}

}  // namespace relume::drivers::aravis
