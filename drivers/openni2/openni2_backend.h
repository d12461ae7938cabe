// The OpenNI2 backend (name "openni2"): Kinect-like depth + colour sensors through libOpenNI2
// and its drivers (PrimeSense/ASUS Xtion, Kinect via third-party drivers, .oni recordings).
//
// Conventions:
//  - OpenNI2 is initialised once per process while any backend object lives, and shut down
//    when the last one goes. It loads its drivers from the OpenNI2/Drivers folder beside
//    libOpenNI2.so.0 (or OpenNI.ini's Drivers.Repository).
//  - DeviceInfo::id is the device URI (e.g. "1d27/0601@1/5", "relume-sim://rgbd/0"); a path
//    ending in ".oni" opens a recording as a device (playback through OpenNI2's file driver;
//    PlaybackControl::seek is not used: it crashes in OpenNI2 2.2 playback).
//  - Frames (RgbdFrame): depth_m is CV_32FC1 metres along the optical axis, NaN where the
//    sensor reports 0 (no measurement); DEPTH_1_MM and DEPTH_100_UM are supported. Colour is
//    RGB888 (R, G, B order, 8 bit, kCameraResponse) or GRAY8 (mono).
//  - Intrinsics come from the streams' horizontal/vertical field of view (centred principal
//    point, shifted by the cropping origin when cropping is on). OpenNI2 does not report the
//    depth-to-colour extrinsics: color_from_depth is the identity when registered, else
//    OpenNI2BackendOptions::color_from_depth (the user's calibration; identity by default).
//  - Timing: device_timestamp = the frame's OpenNI timestamp (device clock, microseconds, as
//    nanoseconds); sequence = the frame index.
//  - With sync_depth_and_color, WaitForFrame returns depth and colour frames of the same frame
//    index (OpenNI2's depth/colour sync); without it, the newest of each.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "drivers/backend.h"

namespace relume::drivers::openni2 {

struct OpenNI2BackendOptions {
  Eigen::Isometry3d color_from_depth = Eigen::Isometry3d::Identity();  // used when not registered
  bool IsValid(std::string* why) const;
};

class OpenNI2Sensor;

class OpenNI2Backend : public Backend {
 public:
  // Initialises OpenNI2 (once per process). Throws DeviceError(kIo) when it cannot.
  explicit OpenNI2Backend(OpenNI2BackendOptions options = {});
  ~OpenNI2Backend() override;
  std::string name() const override { return "openni2"; }
  std::vector<DeviceInfo> Enumerate() override;
  // OpenNI2 drives no still cameras: throws InvalidArgumentError.
  std::unique_ptr<StillCamera> OpenStillCamera(const DeviceInfo& info) override;
  // Opens the device by URI (or a .oni recording by path). Throws DeviceError(kNotFound) when
  // it is not there, saying which devices OpenNI2 sees ("no devices found" when none).
  std::unique_ptr<RgbdSensor> OpenRgbdSensor(const DeviceInfo& info) override;
  std::unique_ptr<OpenNI2Sensor> Open(const std::string& uri_or_oni_path);

  struct Runtime;

 private:
  OpenNI2BackendOptions options_;
  std::shared_ptr<Runtime> runtime_;
};

class OpenNI2Sensor : public RgbdSensor {
 public:
  ~OpenNI2Sensor() override;
  const DeviceInfo& info() const override { return info_; }
  std::vector<RgbdStreamConfig> SupportedConfigs() const override { return configs_; }
  void Start(const RgbdStreamConfig& config) override;
  void Stop() override;
  bool streaming() const override { return streaming_; }
  RgbdFrame WaitForFrame(Nanoseconds timeout) override;

  // Whether the device can resample depth into the colour camera (IMAGE_REGISTRATION_DEPTH_TO_COLOR).
  bool SupportsRegistration() const;
  // True when the device reports registration on (read back from the device, not remembered).
  bool RegistrationEnabled() const;
  // True when this is a recording being played back.
  bool IsPlayback() const;
  // Frames in a recording's depth stream (playback only; else 0).
  int RecordingFrameCount() const;

  // Records the running depth and colour streams to an .oni file (openni::Recorder) until
  // StopRecording or Stop. Throws InvalidArgumentError when not streaming, IoError when the
  // file cannot be created.
  void StartRecording(const std::string& oni_path);
  void StopRecording();
  bool recording() const;

 private:
  friend class OpenNI2Backend;
  struct State;
  OpenNI2Sensor(std::shared_ptr<OpenNI2Backend::Runtime> runtime, const std::string& uri,
                const OpenNI2BackendOptions& options);

  std::unique_ptr<State> state_;
  DeviceInfo info_;
  std::vector<RgbdStreamConfig> configs_;
  bool streaming_ = false;
};

}  // namespace relume::drivers::openni2
