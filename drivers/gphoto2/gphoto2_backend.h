// The libgphoto2 backend (name "gphoto2"): DSLRs and other cameras that libgphoto2 drives
// (PTP over USB, PTP/IP, mass storage). Enumerate = libgphoto2's autodetection (USB cameras)
// plus the cameras listed in GPhoto2BackendOptions::configured (ports libgphoto2 cannot
// autodetect: PTP/IP "ptpip:<address>", "disk:<folder>"), each probed by opening it.
//
// Conventions:
//  - DeviceInfo::id is "<model>@<port>" (e.g. "Nikon DSC D750@usb:001,007"); address = port.
//    USB port numbers change when a camera is replugged; Enumerate again to find it.
//  - Settings go through the camera's configuration tree by widget name (shutterspeed,
//    aperture, iso, exposurecompensation, capturetarget). Every value is checked against the
//    widget's own choices before it is sent: libgphoto2 passes on values the camera does not
//    offer, so an unchecked value can silently give a different exposure. A value that is not
//    offered throws DeviceError(kUnsupportedSetting) and changes nothing.
//  - Capture = gp_camera_capture + gp_camera_file_get. StillFrame::original_file holds the
//    camera's file byte for byte; original_format comes from the file name (else the MIME type).
//    StillFrame::image holds decoded pixels: RGB, 8 or 16 bit, SampleEncoding::kCameraResponse
//    for JPEG, TIFF and PNG; for raw formats (NEF, CR2, CR3, ARW, DNG, ...) the sensor's mosaic
//    decoded by LibRaw (core/raw_file.h: kSensorLinear, Bayer layout, black and white level),
//    so the recorder can meter with it. A raw file LibRaw cannot decode (an unsupported sensor
//    layout such as X-Trans) is still delivered, byte for byte, with an empty image; the reason
//    is in StillFrame::undecoded_reason and the capture layer stores the file as is.
//  - ExposureRecord comes from the configuration values in force at the capture (what the
//    camera reported, not what was asked): NaN for "Auto" ISO or a "bulb" shutter.
//  - Errors: libgphoto2 result codes map onto DeviceErrorKind (gphoto2_values.h): "PTP Device
//    Busy" (GP_ERROR_CAMERA_BUSY) is kBusy, for drivers::RetryingStillCamera to retry (see
//    libgphoto2 issue #334); a camera claimed by another process (GVFS) is kAccessDenied with
//    what to do. Messages include libgphoto2's own error text.
//  - Not thread-safe: one thread per camera (libgphoto2 is not re-entrant per camera).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "drivers/backend.h"

namespace relume::drivers::gphoto2 {

struct GPhoto2CameraAddress {
  std::string model;  // as libgphoto2's abilities list names it, e.g. "Canon EOS 5D Mark III"
  std::string port;   // e.g. "usb:001,007", "ptpip:192.168.1.1", "disk:/path"
};

struct GPhoto2BackendOptions {
  bool autodetect = true;                        // ask libgphoto2 for USB cameras
  std::vector<GPhoto2CameraAddress> configured;  // cameras on ports libgphoto2 cannot autodetect
  // When set, written to the camera's "capturetarget" widget at open (e.g. "Internal RAM",
  // "Memory card"); must be one of its choices.
  std::string capture_target;
  // Delete each captured file from the camera after download (keeps the camera's RAM or card
  // from filling up). Off keeps a copy on the camera. A refused delete does not lose the frame:
  // it is noted in DeviceInfo::details["last_delete_error"].
  bool delete_after_download = true;
  bool IsValid(std::string* why) const;
};

class GPhoto2Camera;

class GPhoto2Backend : public Backend {
 public:
  explicit GPhoto2Backend(GPhoto2BackendOptions options = {});
  ~GPhoto2Backend() override;
  std::string name() const override { return "gphoto2"; }
  std::vector<DeviceInfo> Enumerate() override;
  std::unique_ptr<StillCamera> OpenStillCamera(const DeviceInfo& info) override;
  // gphoto2 has no depth sensors: throws InvalidArgumentError.
  std::unique_ptr<RgbdSensor> OpenRgbdSensor(const DeviceInfo& info) override;

  // Opens by model and port directly (the same as OpenStillCamera on an enumerated info).
  std::unique_ptr<GPhoto2Camera> Open(const GPhoto2CameraAddress& address);
  // Every camera model the loaded camera drivers support (libgphoto2's abilities list).
  std::vector<std::string> SupportedModels();

  struct Library;  // libgphoto2 state (abilities and port lists, context), shared with cameras

 private:
  GPhoto2BackendOptions options_;
  std::shared_ptr<Library> library_;
};

class GPhoto2Camera : public StillCamera {
 public:
  ~GPhoto2Camera() override;
  const DeviceInfo& info() const override { return info_; }
  ExposureCapabilities capabilities() const override { return capabilities_; }
  void Apply(const ExposureSettings& settings) override;
  StillFrame Capture() override;

  // The configuration tree by widget name (as `gphoto2 --list-config` shows the leaves).
  std::vector<std::string> ConfigNames();
  std::string GetConfigValue(const std::string& name);
  std::vector<std::string> ConfigChoices(const std::string& name);
  // Sets one widget by value, validated against its choices (radio/menu), range or toggle.
  // Throws DeviceError(kUnsupportedSetting) for an unknown widget, a read-only one, or a value
  // the widget does not offer.
  void SetConfigValue(const std::string& name, const std::string& value);

 private:
  friend class GPhoto2Backend;
  struct State;
  GPhoto2Camera(std::shared_ptr<GPhoto2Backend::Library> library, const GPhoto2CameraAddress& address,
                const GPhoto2BackendOptions& options);
  void RefreshFromConfig();

  std::unique_ptr<State> state_;
  DeviceInfo info_;
  ExposureCapabilities capabilities_;
  ExposureRecord current_;
  std::uint64_t sequence_ = 0;
};

}  // namespace relume::drivers::gphoto2
