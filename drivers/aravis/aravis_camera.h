// A GenICam camera (GigE Vision, USB3 Vision, or Aravis's own fake) through Aravis's
// arv_camera_* API, as a drivers::StillCamera plus continuous streaming.
//
// Conventions:
//  - Exposure is set in seconds here and in microseconds on the wire (ExposureTime /
//    ExposureTimeAbs, whichever the camera has; Aravis picks). Values outside the bounds the
//    camera reports throw DeviceError(kUnsupportedSetting) and change nothing.
//  - Gain: SFNC "Gain" is in dB. A camera that only has "GainRaw" (vendor units, e.g. the
//    Aravis fake) gets gain_db = raw * Options::raw_gain_db_per_step; with the default 0 the
//    dB scale is unknown and gain cannot be set in dB (capabilities report min = max = 0).
//  - Images: Mono8/10/12/14/16, Bayer 8/16 and RGB8/BGR8 become CameraImage with
//    encoding kSensorLinear (what the sensor counted, no response curve), channels R, G, B,
//    bits_per_sample from the pixel format, black_level 0 (the camera's BlackLevel offset is
//    not subtracted), white_level 2^bits - 1.
//  - Timing (stream_timing.h): FrameTiming::device_timestamp is the camera's timestamp,
//    host_utc the host time Aravis recorded for the buffer (leader packet arrival on GigE),
//    sequence the unwrapped frame id. StreamFrame adds the device time mapped to host time.
//  - Capture() returns a frame whose exposure started after the call began: frames already in
//    flight or queued are dropped, so settings applied before Capture() are in effect.
//  - Errors: GErrors from Aravis map onto DeviceErrorKind (KindFromGError); the device's
//    "control-lost" signal (GigE heartbeat failed, cable pulled) makes every later call
//    throw kDisconnected.
#pragma once

#include <atomic>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivers/aravis/stream_timing.h"
#include "drivers/device_error.h"
#include "drivers/still_camera.h"

// Aravis / GLib types, kept out of users' includes.
typedef struct _ArvCamera ArvCamera;
typedef struct _ArvDevice ArvDevice;
typedef struct _ArvStream ArvStream;
typedef struct _ArvBuffer ArvBuffer;
typedef struct _GError GError;

namespace relume::drivers::aravis {

// Maps an Aravis / GIO error onto the driver error kinds (timeout, I/O, not found, access
// denied, busy, disconnected, unsupported setting).
DeviceErrorKind KindFromGError(const GError* error);
// Throws DeviceError built from `error` (and frees it) when it is set.
void ThrowIfGError(GError* error, const std::string& device_id, const std::string& doing);

struct AravisCameraOptions {
  int buffer_count = 8;                                 // buffers in the stream pool
  Nanoseconds frame_timeout = std::chrono::seconds(3);  // beyond the exposure time
  double raw_gain_db_per_step = 0.0;                    // dB per GainRaw step, 0 = unknown (see top)
  std::string pixel_format;                             // set at open when not empty ("Mono16", ...)
  FrameIdUnwrapperOptions frame_ids;                    // counter width; 16 for GigE Vision 1.x
  DeviceClockMapperOptions clock;
  bool IsValid(std::string* why) const;
};

struct StreamFrame {
  StillFrame frame;
  std::uint64_t raw_frame_id = 0;                  // as the camera sent it
  std::uint64_t frames_lost_before = 0;            // ids skipped since the previous frame
  std::optional<UtcTime> device_time_in_host_utc;  // device timestamp mapped to host time
};

struct StreamStatistics {
  std::uint64_t delivered = 0;  // good frames returned
  std::uint64_t failed = 0;     // buffers that arrived incomplete (missing packets, timeout)
  std::uint64_t lost_ids = 0;   // frame ids that never arrived
  std::uint64_t wraps = 0;      // frame-id counter wrap-arounds seen
  std::uint64_t underruns = 0;  // frames the stream had no free buffer for (Aravis's count)
};

class AravisCamera : public StillCamera {
 public:
  // Opens the Aravis device `aravis_device` (an Aravis id or an address) and describes it as
  // `info`. Throws DeviceError (kNotFound, kAccessDenied, ...).
  AravisCamera(DeviceInfo info, const std::string& aravis_device, AravisCameraOptions options = {});
  ~AravisCamera() override;
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  const DeviceInfo& info() const override { return info_; }
  ExposureCapabilities capabilities() const override { return capabilities_; }
  void Apply(const ExposureSettings& settings) override;
  StillFrame Capture() override;

  // One frame per exposure time, in the given order; restores the exposure time it found.
  std::vector<StillFrame> CaptureBracket(const std::vector<double>& exposure_times_s);

  std::vector<std::string> AvailablePixelFormats() const;
  // Throws kUnsupportedSetting for formats the camera or relume does not handle.
  void SetPixelFormat(const std::string& name);
  std::string pixel_format() const;
  void SetRegion(int x, int y, int width, int height);
  // Frames per second of free-running acquisition, when the camera has AcquisitionFrameRate.
  void SetFrameRate(double frames_per_s);
  double exposure_time_s() const;
  double gain_db() const;

  // Continuous acquisition through the buffer pool.
  void StartStreaming();
  void StopStreaming();
  bool streaming() const { return streaming_; }
  // The next good frame; kTimeout when none arrives in time, kDisconnected after control-lost.
  StreamFrame WaitForFrame(Nanoseconds timeout);
  StreamStatistics statistics() const;
  const DeviceClockFitSummary& clock_fit() const { return clock_.summary(); }
  bool control_lost() const { return control_lost_.load(); }

  // The underlying Aravis objects (tests reach the fake camera through the device).
  ArvCamera* native_camera() const { return camera_; }
  ArvDevice* native_device() const;

 private:
  void ThrowIfLost() const;
  void Refresh();  // re-reads capabilities and payload after a format or region change
  void EnsureStream();
  void DestroyStream();
  void StartAcquisition();
  void StopAcquisition();
  // Pops buffers until a good one whose host timestamp is >= not_before_ns (0: any).
  StreamFrame PopFrame(Nanoseconds timeout, std::uint64_t not_before_ns);
  StreamFrame Account(ArvBuffer* buffer);  // timing, ids, exposure record
  void ConvertImage(ArvBuffer* buffer, StreamFrame* frame) const;
  void ReadBackExposure();
  static void OnControlLost(ArvDevice* device, void* self);

  DeviceInfo info_;
  AravisCameraOptions options_;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  unsigned long control_lost_handler_ = 0;
  std::atomic<bool> control_lost_{false};
  ExposureCapabilities capabilities_;
  bool gain_is_raw_ = false;
  std::size_t payload_ = 0;
  double exposure_s_ = NAN;  // as last read back from the camera
  double gain_db_ = NAN;
  bool acquiring_ = false;
  bool streaming_ = false;
  std::uint64_t stream_start_ns_ = 0;
  FrameIdUnwrapper frame_ids_;
  DeviceClockMapper clock_;
  StreamStatistics stats_;
};

}  // namespace relume::drivers::aravis
