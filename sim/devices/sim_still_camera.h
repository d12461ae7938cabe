// A simulated still camera behind drivers::StillCamera. Each Capture() renders the TruthSource
// at the clock's time through the camera model (sim/devices/camera_model.h), with the exposure
// control of one of the three modes (sim/devices/exposure_modes.h), and the faults of its
// DeviceLink (sim/devices/faults.h).
//
// Timing of one capture, all on the Clock the camera was given:
//   t0 = clock now -> truth rendered at t0 (EV-only cameras meter on that render) ->
//   clock sleeps exposure_time + readout_time -> host_utc/host_monotonic = clock now.
//   device_timestamp = device clock (offset, drift, injected jumps) at t0.
// The frame's `image` is the raw sensor image (kSensorLinear) or the camera-encoded 8-bit image
// (kCameraResponse), as `output` says; original_file holds the same pixels as the camera's
// file: a TIFF of the raw counts (16-bit, or 8-bit for 8-bit sensors; Bayer mosaics as one
// channel) or a PNG of the encoded image, both lossless so that decoding gives `image` back.
#pragma once

#include <memory>
#include <optional>

#include "core/clock.h"
#include "drivers/still_camera.h"
#include "sim/devices/camera_model.h"
#include "sim/devices/exposure_modes.h"
#include "sim/devices/faults.h"
#include "sim/truth.h"

namespace relume::sim {

struct SimStillCameraOptions {
  enum class Output { kRaw, kEncoded };
  drivers::ExposureControl control = drivers::ExposureControl::kShutterList;
  drivers::ExposureCapabilities capabilities = DslrCapabilities();  // must match `control`
  CameraModelOptions model;
  MeteringOptions metering;  // kEvOnly
  Output output = Output::kRaw;
  bool add_noise = true;
  // Exposure before any Apply(); where a setting is not settable this is its fixed value.
  ExposureParams initial_exposure{1.0 / 125, 8.0, 100.0, 0.0};
  double readout_time_s = 0.0;
  DeviceClockOptions device_clock;
  std::optional<double> sensor_temperature_c;

  // Options for one of the three modes with its default capabilities.
  static SimStillCameraOptions ForControl(drivers::ExposureControl control);
  bool IsValid(std::string* why) const;
};

class SimStillCamera : public drivers::StillCamera {
 public:
  // `link` is the device's shared connection state (the backend's); nullptr makes a private
  // one without faults. Claims the link: a second open handle throws kAccessDenied.
  SimStillCamera(drivers::DeviceInfo info, SimStillCameraOptions options, PinholeCamera camera,
                 std::shared_ptr<const TruthSource> truth, std::shared_ptr<Clock> clock,
                 std::shared_ptr<DeviceLink> link = nullptr);
  ~SimStillCamera() override;
  SimStillCamera(const SimStillCamera&) = delete;
  SimStillCamera& operator=(const SimStillCamera&) = delete;

  const drivers::DeviceInfo& info() const override { return info_; }
  drivers::ExposureCapabilities capabilities() const override;
  void Apply(const drivers::ExposureSettings& settings) override;
  drivers::StillFrame Capture() override;

  // The exposure the next capture uses (for EV-only cameras: its aperture, ISO and gain).
  const ExposureParams& exposure() const { return exposure_; }
  double ev_compensation() const { return ev_compensation_; }
  const PinholeCamera& camera() const { return camera_; }

 private:
  void ThrowIfGone() const;

  drivers::DeviceInfo info_;
  SimStillCameraOptions options_;
  PinholeCamera camera_;
  std::shared_ptr<const TruthSource> truth_;
  std::shared_ptr<Clock> clock_;
  std::shared_ptr<DeviceLink> link_;
  std::uint64_t generation_ = 0;
  ExposureParams exposure_;
  double ev_compensation_ = 0.0;
};

// Encodes a camera image as the camera's file: "tiff" for raw, "png" for encoded (RGB is
// written in the file's BGR order). Throws IoError when OpenCV cannot encode it.
std::vector<std::uint8_t> EncodeCameraFile(const CameraImage& image, std::string* format);

}  // namespace relume::sim
