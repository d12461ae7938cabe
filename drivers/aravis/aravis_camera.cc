#include "drivers/aravis/aravis_camera.h"

extern "C" {
#include <arv.h>
}

#include <algorithm>
#include <cmath>
#include <thread>

#include "drivers/aravis/pixel_formats.h"

namespace relume::drivers::aravis {
namespace {

std::uint64_t RealTimeNs() {
  return static_cast<std::uint64_t>(g_get_real_time()) * 1000u;
}

bool IsFakeDevice(ArvDevice* device) {
  return device != nullptr &&
         g_type_check_instance_is_a(reinterpret_cast<GTypeInstance*>(device), arv_fake_device_get_type());
}

DeviceErrorKind KindFromDeviceError(int code) {
  switch (code) {
    case ARV_DEVICE_ERROR_TIMEOUT: return DeviceErrorKind::kTimeout;
    case ARV_DEVICE_ERROR_NOT_CONNECTED: return DeviceErrorKind::kDisconnected;
    case ARV_DEVICE_ERROR_NOT_FOUND:
    case ARV_DEVICE_ERROR_GENICAM_NOT_FOUND: return DeviceErrorKind::kNotFound;
    case ARV_DEVICE_ERROR_NOT_CONTROLLER:
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_ACCESS_DENIED: return DeviceErrorKind::kAccessDenied;
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_BUSY: return DeviceErrorKind::kBusy;
    case ARV_DEVICE_ERROR_WRONG_FEATURE:
    case ARV_DEVICE_ERROR_FEATURE_NOT_FOUND:
    case ARV_DEVICE_ERROR_INVALID_PARAMETER:
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_NOT_IMPLEMENTED:
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_INVALID_PARAMETER:
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_INVALID_ADDRESS:
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_WRITE_PROTECT:
    case ARV_DEVICE_ERROR_PROTOCOL_ERROR_BAD_ALIGNMENT: return DeviceErrorKind::kUnsupportedSetting;
    default: return DeviceErrorKind::kIo;  // protocol, transfer, no stream channel, unknown
  }
}

DeviceErrorKind KindFromIoError(int code) {
  switch (code) {
    case G_IO_ERROR_TIMED_OUT: return DeviceErrorKind::kTimeout;
    case G_IO_ERROR_PERMISSION_DENIED: return DeviceErrorKind::kAccessDenied;
    case G_IO_ERROR_NOT_FOUND: return DeviceErrorKind::kNotFound;
    case G_IO_ERROR_BUSY:
    case G_IO_ERROR_ADDRESS_IN_USE: return DeviceErrorKind::kBusy;
    case G_IO_ERROR_CONNECTION_REFUSED:
    case G_IO_ERROR_CONNECTION_CLOSED:
    case G_IO_ERROR_HOST_UNREACHABLE:
    case G_IO_ERROR_NETWORK_UNREACHABLE: return DeviceErrorKind::kDisconnected;
    default: return DeviceErrorKind::kIo;
  }
}

const char* BufferStatusName(ArvBufferStatus status) {
  switch (status) {
    case ARV_BUFFER_STATUS_SUCCESS: return "success";
    case ARV_BUFFER_STATUS_CLEARED: return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT: return "timeout before all packets arrived";
    case ARV_BUFFER_STATUS_MISSING_PACKETS: return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID: return "wrong packet id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH: return "image larger than the buffer";
    case ARV_BUFFER_STATUS_FILLING: return "still filling";
    case ARV_BUFFER_STATUS_ABORTED: return "aborted";
    default: return "unknown";
  }
}

}  // namespace

DeviceErrorKind KindFromGError(const GError* error) {
  if (error == nullptr) return DeviceErrorKind::kIo;
  if (error->domain == arv_device_error_quark()) return KindFromDeviceError(error->code);
  if (error->domain == arv_gc_error_quark()) {
    // Out of range, read-only, no such node or enum entry: the setting is not offered.
    return DeviceErrorKind::kUnsupportedSetting;
  }
  if (error->domain == g_io_error_quark()) return KindFromIoError(error->code);
  return DeviceErrorKind::kIo;
}

void ThrowIfGError(GError* error, const std::string& device_id, const std::string& doing) {
  if (error == nullptr) return;
  const DeviceErrorKind kind = KindFromGError(error);
  const std::string message = doing + ": " + error->message;
  g_error_free(error);
  throw DeviceError(kind, device_id, message);
}

bool AravisCameraOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (buffer_count < 2 || buffer_count > 256) return fail("buffer_count must be within 2..256");
  if (frame_timeout <= Nanoseconds(0)) return fail("frame_timeout must be positive");
  if (!(std::isfinite(raw_gain_db_per_step) && raw_gain_db_per_step >= 0.0))
    return fail("raw_gain_db_per_step must be finite and >= 0");
  if (!pixel_format.empty() && !FindPixelFormat(pixel_format)) return fail("pixel_format is not one relume reads");
  if (!frame_ids.IsValid(why) || !clock.IsValid(why)) return false;
  return true;
}

AravisCamera::AravisCamera(DeviceInfo info, const std::string& aravis_device, AravisCameraOptions options)
    : info_(std::move(info)), options_(std::move(options)), frame_ids_(options_.frame_ids), clock_(options_.clock) {
  ThrowIfInvalid(options_, "AravisCameraOptions");
  GError* error = nullptr;
  camera_ = arv_camera_new(aravis_device.c_str(), &error);
  if (camera_ == nullptr) {
    if (error == nullptr) {
      throw DeviceError(DeviceErrorKind::kNotFound, info_.FullId(), "Aravis cannot open '" + aravis_device + "'");
    }
    ThrowIfGError(error, info_.FullId(), "opening '" + aravis_device + "'");
  }
  try {
    control_lost_handler_ = g_signal_connect_data(arv_camera_get_device(camera_), "control-lost",
                                                  reinterpret_cast<GCallback>(&AravisCamera::OnControlLost), this,
                                                  nullptr, GConnectFlags(0));
    // Radiometric work needs the exposure and gain we set, not the camera's automatics.
    if (arv_camera_is_exposure_auto_available(camera_, nullptr)) {
      arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_OFF, &error);
      ThrowIfGError(error, info_.FullId(), "turning ExposureAuto off");
    }
    if (arv_camera_is_gain_auto_available(camera_, nullptr)) {
      arv_camera_set_gain_auto(camera_, ARV_AUTO_OFF, &error);
      ThrowIfGError(error, info_.FullId(), "turning GainAuto off");
    }
    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
    ThrowIfGError(error, info_.FullId(), "setting AcquisitionMode to Continuous");
    if (!options_.pixel_format.empty()) SetPixelFormat(options_.pixel_format);
    Refresh();
  } catch (...) {
    if (control_lost_handler_ != 0) g_signal_handler_disconnect(arv_camera_get_device(camera_), control_lost_handler_);
    g_object_unref(camera_);
    throw;
  }
}

AravisCamera::~AravisCamera() {
  DestroyStream();
  if (control_lost_handler_ != 0) g_signal_handler_disconnect(arv_camera_get_device(camera_), control_lost_handler_);
  g_object_unref(camera_);
}

ArvDevice* AravisCamera::native_device() const {
  return arv_camera_get_device(camera_);
}

void AravisCamera::OnControlLost(ArvDevice* /*device*/, void* self) {
  static_cast<AravisCamera*>(self)->control_lost_.store(true);
}

void AravisCamera::ThrowIfLost() const {
  if (control_lost_.load()) {
    throw DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(),
                      "Aravis lost control of the camera (heartbeat failed: cable, power or network); reopen it");
  }
}

void AravisCamera::Refresh() {
  GError* error = nullptr;
  capabilities_ = {};
  capabilities_.control = ExposureControl::kContinuous;
  double min_us = 0.0, max_us = 0.0;
  arv_camera_get_exposure_time_bounds(camera_, &min_us, &max_us, &error);
  ThrowIfGError(error, info_.FullId(), "reading exposure time bounds");
  capabilities_.min_exposure_time_s = min_us * 1e-6;
  capabilities_.max_exposure_time_s = max_us * 1e-6;
  const bool has_db_gain = arv_camera_is_feature_available(camera_, "Gain", nullptr) ||
                           arv_camera_is_feature_available(camera_, "GainAbs", nullptr);
  gain_is_raw_ = !has_db_gain && arv_camera_is_feature_available(camera_, "GainRaw", nullptr);
  if (has_db_gain || gain_is_raw_) {
    double min_gain = 0.0, max_gain = 0.0;
    arv_camera_get_gain_bounds(camera_, &min_gain, &max_gain, &error);
    ThrowIfGError(error, info_.FullId(), "reading gain bounds");
    const double scale = gain_is_raw_ ? options_.raw_gain_db_per_step : 1.0;
    capabilities_.min_gain_db = min_gain * scale;
    capabilities_.max_gain_db = max_gain * scale;
  }
  payload_ = arv_camera_get_payload(camera_, &error);
  ThrowIfGError(error, info_.FullId(), "reading the payload size");
  ReadBackExposure();
}

double AravisCamera::exposure_time_s() const {
  GError* error = nullptr;
  const double us = arv_camera_get_exposure_time(camera_, &error);
  ThrowIfGError(error, info_.FullId(), "reading the exposure time");
  return us * 1e-6;
}

double AravisCamera::gain_db() const {
  if (!gain_is_raw_ && capabilities_.max_gain_db == capabilities_.min_gain_db) return capabilities_.min_gain_db;
  GError* error = nullptr;
  const double gain = arv_camera_get_gain(camera_, &error);
  ThrowIfGError(error, info_.FullId(), "reading the gain");
  return gain_is_raw_ ? gain * options_.raw_gain_db_per_step : gain;
}

void AravisCamera::Apply(const ExposureSettings& settings) {
  ThrowIfLost();
  auto unsupported = [&](const std::string& what) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(), what);
  };
  // Validate everything first so that a bad value changes nothing.
  if (settings.ev_compensation) unsupported("EV compensation is not offered; set exposure_time_s");
  if (settings.aperture_f) unsupported("the aperture is not controlled by the camera (set it on the lens)");
  if (settings.iso) unsupported("ISO is not offered by machine-vision cameras; set gain_db");
  if (settings.exposure_time_s) {
    const double t = *settings.exposure_time_s;
    if (!(std::isfinite(t) && t >= capabilities_.min_exposure_time_s && t <= capabilities_.max_exposure_time_s)) {
      unsupported("exposure time " + std::to_string(t) + " s is outside the camera's range [" +
                  std::to_string(capabilities_.min_exposure_time_s) + ", " +
                  std::to_string(capabilities_.max_exposure_time_s) + "] s");
    }
  }
  if (settings.gain_db) {
    const double g = *settings.gain_db;
    if (gain_is_raw_ && options_.raw_gain_db_per_step == 0.0) {
      unsupported("the camera has only GainRaw in vendor units; set AravisCameraOptions::raw_gain_db_per_step");
    }
    if (!(std::isfinite(g) && g >= capabilities_.min_gain_db - 1e-9 && g <= capabilities_.max_gain_db + 1e-9)) {
      unsupported("gain " + std::to_string(g) + " dB is outside the camera's range [" +
                  std::to_string(capabilities_.min_gain_db) + ", " + std::to_string(capabilities_.max_gain_db) +
                  "] dB");
    }
  }
  GError* error = nullptr;
  if (settings.exposure_time_s) {
    arv_camera_set_exposure_time(camera_, *settings.exposure_time_s * 1e6, &error);
    ThrowIfGError(error, info_.FullId(), "setting the exposure time");
  }
  if (settings.gain_db && capabilities_.max_gain_db > capabilities_.min_gain_db) {
    if (gain_is_raw_) {
      const double raw = std::round(*settings.gain_db / options_.raw_gain_db_per_step);
      arv_camera_set_integer(camera_, "GainRaw", static_cast<gint64>(raw), &error);
    } else {
      arv_camera_set_gain(camera_, *settings.gain_db, &error);
    }
    ThrowIfGError(error, info_.FullId(), "setting the gain");
  }
  ReadBackExposure();
}

void AravisCamera::ReadBackExposure() {
  // Cameras quantise what they are given: frames record what the camera reports.
  exposure_s_ = exposure_time_s();
  gain_db_ = gain_is_raw_ && options_.raw_gain_db_per_step == 0.0 ? NAN : gain_db();
}

std::vector<std::string> AravisCamera::AvailablePixelFormats() const {
  GError* error = nullptr;
  guint n = 0;
  const char** names = arv_camera_dup_available_pixel_formats_as_strings(camera_, &n, &error);
  ThrowIfGError(error, info_.FullId(), "listing pixel formats");
  std::vector<std::string> out;
  for (guint i = 0; i < n; ++i) {
    if (FindPixelFormat(names[i])) out.emplace_back(names[i]);
  }
  g_free(static_cast<void*>(names));
  return out;
}

void AravisCamera::SetPixelFormat(const std::string& name) {
  ThrowIfLost();
  const std::vector<std::string> available = AvailablePixelFormats();
  if (!FindPixelFormat(name) || std::find(available.begin(), available.end(), name) == available.end()) {
    std::string list;
    for (const std::string& a : available) list += (list.empty() ? "" : ", ") + a;
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(),
                      "pixel format '" + name + "' is not offered or not read by relume; choose one of: " + list);
  }
  if (streaming_) StopStreaming();
  DestroyStream();
  GError* error = nullptr;
  arv_camera_set_pixel_format_from_string(camera_, name.c_str(), &error);
  ThrowIfGError(error, info_.FullId(), "setting PixelFormat to " + name);
  Refresh();
}

std::string AravisCamera::pixel_format() const {
  GError* error = nullptr;
  const char* name = arv_camera_get_pixel_format_as_string(camera_, &error);
  ThrowIfGError(error, info_.FullId(), "reading PixelFormat");
  return name != nullptr ? name : "";
}

void AravisCamera::SetRegion(int x, int y, int width, int height) {
  ThrowIfLost();
  if (streaming_) StopStreaming();
  DestroyStream();
  GError* error = nullptr;
  arv_camera_set_region(camera_, x, y, width, height, &error);
  ThrowIfGError(error, info_.FullId(), "setting the region");
  Refresh();
}

void AravisCamera::SetFrameRate(double frames_per_s) {
  ThrowIfLost();
  GError* error = nullptr;
  double min_fps = 0.0, max_fps = 0.0;
  arv_camera_get_frame_rate_bounds(camera_, &min_fps, &max_fps, &error);
  ThrowIfGError(error, info_.FullId(), "reading frame rate bounds");
  if (!(std::isfinite(frames_per_s) && frames_per_s >= min_fps && frames_per_s <= max_fps)) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(),
                      "frame rate " + std::to_string(frames_per_s) + " is outside [" + std::to_string(min_fps) + ", " +
                          std::to_string(max_fps) + "] frames/s");
  }
  arv_camera_set_frame_rate(camera_, frames_per_s, &error);
  ThrowIfGError(error, info_.FullId(), "setting the frame rate");
}

void AravisCamera::EnsureStream() {
  if (stream_ != nullptr) return;
  GError* error = nullptr;
  stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
  if (stream_ == nullptr) {
    if (error == nullptr) throw DeviceError(DeviceErrorKind::kIo, info_.FullId(), "Aravis could not create a stream");
    ThrowIfGError(error, info_.FullId(), "creating the stream");
  }
  for (int i = 0; i < options_.buffer_count; ++i) arv_stream_push_buffer(stream_, arv_buffer_new_allocate(payload_));
}

void AravisCamera::DestroyStream() {
  if (acquiring_) StopAcquisition();
  if (stream_ != nullptr) {
    g_object_unref(stream_);  // stops the stream thread and frees the pool
    stream_ = nullptr;
  }
}

void AravisCamera::StartAcquisition() {
  GError* error = nullptr;
  arv_camera_start_acquisition(camera_, &error);
  ThrowIfGError(error, info_.FullId(), "starting acquisition");
  acquiring_ = true;
}

void AravisCamera::StopAcquisition() {
  acquiring_ = false;
  GError* error = nullptr;
  arv_camera_stop_acquisition(camera_, &error);
  if (error != nullptr) g_error_free(error);  // stopping a lost camera fails; nothing to undo
}

StreamFrame AravisCamera::PopFrame(Nanoseconds timeout, std::uint64_t not_before_ns) {
  const MonotonicTime deadline = MonotonicNow() + timeout;
  std::string last_problem = "no frame arrived";
  for (;;) {
    ThrowIfLost();
    const Nanoseconds remaining = deadline - MonotonicNow();
    if (remaining <= Nanoseconds(0)) {
      throw DeviceError(
          DeviceErrorKind::kTimeout, info_.FullId(),
          last_problem + " within " + std::to_string(std::chrono::duration<double>(timeout).count()) + " s");
    }
    // Wait in slices so that a lost camera is noticed while waiting.
    const auto slice_us =
        std::min<std::int64_t>(std::chrono::duration_cast<std::chrono::microseconds>(remaining).count() + 1, 100000);
    ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(slice_us));
    if (buffer == nullptr) continue;
    const ArvBufferStatus status = arv_buffer_get_status(buffer);
    if (status != ARV_BUFFER_STATUS_SUCCESS) {
      ++stats_.failed;
      last_problem = std::string("only incomplete frames arrived (") + BufferStatusName(status) + ")";
      arv_stream_push_buffer(stream_, buffer);
      continue;
    }
    const std::uint64_t system_ns = arv_buffer_get_system_timestamp(buffer);
    StreamFrame frame = Account(buffer);                    // ids and clock samples from every good frame
    if (not_before_ns != 0 && system_ns < not_before_ns) {  // begun before the request
      arv_stream_push_buffer(stream_, buffer);
      continue;
    }
    try {
      ConvertImage(buffer, &frame);
    } catch (...) {
      arv_stream_push_buffer(stream_, buffer);
      throw;
    }
    arv_stream_push_buffer(stream_, buffer);
    ++stats_.delivered;
    return frame;
  }
}

StreamFrame AravisCamera::Account(ArvBuffer* buffer) {
  StreamFrame out;
  out.frame.device_id = info_.FullId();
  out.frame.model = info_.model;
  const std::uint64_t device_ns = arv_buffer_get_timestamp(buffer);
  const std::uint64_t system_ns = arv_buffer_get_system_timestamp(buffer);
  const UtcTime now_utc = UtcNow();
  const MonotonicTime now_monotonic = MonotonicNow();
  FrameTiming& timing = out.frame.timing;
  timing.host_utc = system_ns != 0 ? UtcTime(Nanoseconds(static_cast<std::int64_t>(system_ns))) : now_utc;
  timing.host_monotonic = now_monotonic - (now_utc - timing.host_utc);
  if (device_ns != 0) {
    timing.device_timestamp = Nanoseconds(static_cast<std::int64_t>(device_ns));
    clock_.AddSample(*timing.device_timestamp, timing.host_utc);
    out.device_time_in_host_utc = clock_.Map(*timing.device_timestamp);
  }
  out.raw_frame_id = arv_buffer_get_frame_id(buffer);
  if (const std::optional<UnwrappedFrameId> id = frame_ids_.Next(out.raw_frame_id)) {
    out.frames_lost_before = id->lost;
    timing.sequence = id->sequence;
  } else {
    timing.sequence = stats_.delivered;  // duplicate or invalid id: keep the driver's count
  }
  out.frame.exposure.exposure_time_s = exposure_s_;
  out.frame.exposure.gain_db = gain_db_;
  return out;
}

void AravisCamera::ConvertImage(ArvBuffer* buffer, StreamFrame* frame) const {
  size_t size = 0;
  const void* data = arv_buffer_get_image_data(buffer, &size);
  if (size == 0 && IsFakeDevice(native_device())) {
    // Aravis 0.8's fake camera leaves the received size at 0 when a custom fill pattern
    // painted the buffer (the callback cannot set it); the fake always fills the whole
    // payload, which our buffers hold.
    size = payload_;
  }
  gint x_padding = 0, y_padding = 0;
  arv_buffer_get_image_padding(buffer, &x_padding, &y_padding);
  frame->frame.image =
      ImageFromPixels(data, size, arv_buffer_get_image_pixel_format(buffer), arv_buffer_get_image_width(buffer),
                      arv_buffer_get_image_height(buffer), x_padding, info_.FullId());
}

StillFrame AravisCamera::Capture() {
  ThrowIfLost();
  if (streaming_) {
    throw InvalidArgumentError(info_.FullId() + ": Capture() while streaming; call StopStreaming() first");
  }
  EnsureStream();
  const Nanoseconds timeout =
      options_.frame_timeout + std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(exposure_s_));
  const std::uint64_t not_before = RealTimeNs();
  StartAcquisition();
  StreamFrame frame;
  try {
    frame = PopFrame(timeout, not_before);
  } catch (...) {
    StopAcquisition();
    throw;
  }
  StopAcquisition();
  return std::move(frame.frame);
}

std::vector<StillFrame> AravisCamera::CaptureBracket(const std::vector<double>& exposure_times_s) {
  const double original = exposure_time_s();
  std::vector<StillFrame> frames;
  frames.reserve(exposure_times_s.size());
  try {
    for (double t : exposure_times_s) {
      ExposureSettings settings;
      settings.exposure_time_s = t;
      Apply(settings);
      frames.push_back(Capture());
    }
  } catch (...) {
    if (!control_lost_.load()) {
      ExposureSettings restore;
      restore.exposure_time_s = original;
      try {
        Apply(restore);
      } catch (const DeviceError&) {
        // The original error is the one to report.
      }
    }
    throw;
  }
  ExposureSettings restore;
  restore.exposure_time_s = original;
  Apply(restore);
  return frames;
}

void AravisCamera::StartStreaming() {
  ThrowIfLost();
  if (streaming_) return;
  EnsureStream();
  stream_start_ns_ = RealTimeNs();
  StartAcquisition();
  streaming_ = true;
}

void AravisCamera::StopStreaming() {
  if (!streaming_) return;
  StopAcquisition();
  streaming_ = false;
}

StreamFrame AravisCamera::WaitForFrame(Nanoseconds timeout) {
  if (!streaming_) throw InvalidArgumentError(info_.FullId() + ": WaitForFrame() without StartStreaming()");
  return PopFrame(timeout, stream_start_ns_);
}

StreamStatistics AravisCamera::statistics() const {
  StreamStatistics out = stats_;
  out.lost_ids = frame_ids_.total_lost();
  out.wraps = frame_ids_.wraps();
  if (stream_ != nullptr) {
    guint64 completed = 0, failures = 0, underruns = 0;
    arv_stream_get_statistics(stream_, &completed, &failures, &underruns);
    out.underruns = underruns;
  }
  return out;
}

}  // namespace relume::drivers::aravis
