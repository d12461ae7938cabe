#include "drivers/openni2/openni2_backend.h"

// OpenNI.h's inline openni::Array::operator[] trips GCC's -Wnull-dereference (reported in the
// header once inlined, where -isystem does not silence it); the warning is about OpenNI's code.
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <OpenNI.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <sstream>

#include "core/error.h"
#include "drivers/device_error.h"

namespace relume::drivers::openni2 {
namespace {

std::string ExtendedError() {
  const char* text = openni::OpenNI::getExtendedError();
  return text != nullptr && text[0] != '\0' ? text : "no details from OpenNI2";
}

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool IsDepthFormat(openni::PixelFormat format) {
  return format == openni::PIXEL_FORMAT_DEPTH_1_MM || format == openni::PIXEL_FORMAT_DEPTH_100_UM;
}
bool IsColorFormat(openni::PixelFormat format) {
  return format == openni::PIXEL_FORMAT_RGB888 || format == openni::PIXEL_FORMAT_GRAY8;
}

// Intrinsics of a stream from its fields of view, for a frame cropped at (x0, y0).
PinholeIntrinsics IntrinsicsOf(const openni::VideoStream& stream, int full_width, int full_height, int width,
                               int height, int x0, int y0) {
  PinholeIntrinsics intrinsics;
  intrinsics.width = width;
  intrinsics.height = height;
  const double hfov = stream.getHorizontalFieldOfView();
  const double vfov = stream.getVerticalFieldOfView();
  intrinsics.fx = (full_width / 2.0) / std::tan(hfov / 2.0);
  intrinsics.fy = (full_height / 2.0) / std::tan(vfov / 2.0);
  intrinsics.cx = full_width / 2.0 - x0;
  intrinsics.cy = full_height / 2.0 - y0;
  return intrinsics;
}

}  // namespace

// ---- runtime (OpenNI::initialize / shutdown) --------------------------------------------------

struct OpenNI2Backend::Runtime {
  Runtime() {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) {
      throw DeviceError(DeviceErrorKind::kIo, "openni2",
                        "OpenNI2 failed to initialise: " + ExtendedError() +
                            " (it loads its drivers from the OpenNI2/Drivers folder beside libOpenNI2.so.0)");
    }
  }
  ~Runtime() { openni::OpenNI::shutdown(); }
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  static std::shared_ptr<Runtime> Acquire() {
    static std::mutex mutex;
    static std::weak_ptr<Runtime> current;
    std::lock_guard<std::mutex> lock(mutex);
    std::shared_ptr<Runtime> runtime = current.lock();
    if (!runtime) {
      runtime = std::make_shared<Runtime>();
      current = runtime;
    }
    return runtime;
  }
};

bool OpenNI2BackendOptions::IsValid(std::string* why) const {
  if (!color_from_depth.matrix().allFinite() || !color_from_depth.linear().isUnitary(1e-6) ||
      color_from_depth.linear().determinant() < 0.0) {
    if (why) *why = "color_from_depth must be a finite rigid transform (rotation + translation)";
    return false;
  }
  return true;
}

OpenNI2Backend::OpenNI2Backend(OpenNI2BackendOptions options) : options_(std::move(options)) {
  ThrowIfInvalid(options_, "openni2 backend options");
  runtime_ = Runtime::Acquire();
}
OpenNI2Backend::~OpenNI2Backend() = default;

std::vector<DeviceInfo> OpenNI2Backend::Enumerate() {
  openni::Array<openni::DeviceInfo> list;
  openni::OpenNI::enumerateDevices(&list);
  std::vector<DeviceInfo> out;
  for (int i = 0; i < list.getSize(); ++i) {
    DeviceInfo info;
    info.backend = "openni2";
    info.id = list[i].getUri();
    info.kind = DeviceKind::kRgbdSensor;
    info.model = list[i].getName();
    info.address = list[i].getUri();
    info.details["vendor"] = list[i].getVendor();
    std::ostringstream usb;
    usb << std::hex << list[i].getUsbVendorId() << ":" << list[i].getUsbProductId();
    info.details["usb_id"] = usb.str();
    out.push_back(std::move(info));
  }
  return out;
}

std::unique_ptr<StillCamera> OpenNI2Backend::OpenStillCamera(const DeviceInfo& info) {
  throw InvalidArgumentError("openni2 device '" + info.id + "' is a depth sensor, not a still camera");
}

std::unique_ptr<RgbdSensor> OpenNI2Backend::OpenRgbdSensor(const DeviceInfo& info) {
  if (info.kind != DeviceKind::kRgbdSensor) {
    throw InvalidArgumentError("openni2 device '" + info.id + "' is not an RGB-D sensor");
  }
  return Open(info.id);
}

std::unique_ptr<OpenNI2Sensor> OpenNI2Backend::Open(const std::string& uri_or_oni_path) {
  return std::unique_ptr<OpenNI2Sensor>(new OpenNI2Sensor(runtime_, uri_or_oni_path, options_));
}

// ---- sensor ---------------------------------------------------------------------------------

struct OpenNI2Sensor::State {
  std::shared_ptr<OpenNI2Backend::Runtime> runtime;
  OpenNI2BackendOptions options;
  openni::Device device;
  openni::VideoStream depth;
  openni::VideoStream color;
  openni::Recorder recorder;
  bool recording = false;
  bool registered = false;
  bool synced = false;
  openni::VideoFrameRef last_depth;
  openni::VideoFrameRef last_color;
  int last_returned_index = -1;
  bool have_returned = false;

  ~State() {
    // Frames first: they belong to the streams destroyed below.
    last_depth.release();
    last_color.release();
    if (recorder.isValid()) {
      recorder.stop();
      recorder.destroy();
    }
    depth.stop();
    color.stop();
    depth.destroy();
    color.destroy();
    device.close();
  }
};

OpenNI2Sensor::OpenNI2Sensor(std::shared_ptr<OpenNI2Backend::Runtime> runtime, const std::string& uri,
                             const OpenNI2BackendOptions& options)
    : state_(std::make_unique<State>()) {
  state_->runtime = std::move(runtime);
  state_->options = options;
  info_.backend = "openni2";
  info_.id = uri;
  info_.kind = DeviceKind::kRgbdSensor;
  info_.address = uri;
  const std::string id = info_.FullId();
  const bool is_file = EndsWith(uri, ".oni");
  if (is_file) {
    if (!std::filesystem::is_regular_file(uri)) {
      throw DeviceError(DeviceErrorKind::kNotFound, id, "no recording '" + uri + "'");
    }
  } else {
    openni::Array<openni::DeviceInfo> list;
    openni::OpenNI::enumerateDevices(&list);
    bool present = false;
    std::string available;
    for (int i = 0; i < list.getSize(); ++i) {
      present = present || uri == list[i].getUri();
      available += std::string(available.empty() ? "" : ", ") + list[i].getUri();
    }
    if (!present) {
      throw DeviceError(DeviceErrorKind::kNotFound, id,
                        list.getSize() == 0
                            ? "OpenNI2 found no devices (no devices found): is the sensor plugged in and powered, "
                              "and is its driver in the OpenNI2/Drivers folder beside libOpenNI2.so.0?"
                            : "OpenNI2 sees no such device; it sees: " + available);
    }
  }
  if (state_->device.open(uri.c_str()) != openni::STATUS_OK) {
    throw DeviceError(
        is_file ? DeviceErrorKind::kIo : DeviceErrorKind::kAccessDenied, id,
        "OpenNI2 cannot open it: " + ExtendedError() +
            (is_file ? "" : " (permissions: install the sensor's udev rules, or another process has it)"));
  }
  info_.model = state_->device.getDeviceInfo().getName();
  info_.details["vendor"] = state_->device.getDeviceInfo().getVendor();
  char serial[256] = {0};
  int size = sizeof(serial);
  if (state_->device.getProperty(openni::DEVICE_PROPERTY_SERIAL_NUMBER, serial, &size) == openni::STATUS_OK) {
    info_.serial = serial;
  }
  if (is_file) {
    if (openni::PlaybackControl* playback = state_->device.getPlaybackControl()) {
      playback->setRepeatEnabled(false);
      playback->setSpeed(1.0f);
    }
  }
  const openni::SensorInfo* depth_info = state_->device.getSensorInfo(openni::SENSOR_DEPTH);
  const openni::SensorInfo* color_info = state_->device.getSensorInfo(openni::SENSOR_COLOR);
  if (depth_info == nullptr || color_info == nullptr) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id,
                      "the device does not have both a depth and a colour sensor");
  }
  const bool can_register = SupportsRegistration();
  const auto& depth_modes = depth_info->getSupportedVideoModes();
  const auto& color_modes = color_info->getSupportedVideoModes();
  for (int d = 0; d < depth_modes.getSize(); ++d) {
    if (!IsDepthFormat(depth_modes[d].getPixelFormat())) continue;
    for (int c = 0; c < color_modes.getSize(); ++c) {
      if (!IsColorFormat(color_modes[c].getPixelFormat()) || color_modes[c].getFps() != depth_modes[d].getFps()) {
        continue;
      }
      for (const bool registered : {false, true}) {
        if (registered && !can_register) continue;
        for (const bool synced : {true, false}) {
          RgbdStreamConfig config;
          config.depth_width = depth_modes[d].getResolutionX();
          config.depth_height = depth_modes[d].getResolutionY();
          config.color_width = color_modes[c].getResolutionX();
          config.color_height = color_modes[c].getResolutionY();
          config.fps = depth_modes[d].getFps();
          config.register_depth_to_color = registered;
          config.sync_depth_and_color = synced;
          const bool duplicate = std::any_of(configs_.begin(), configs_.end(), [&](const RgbdStreamConfig& other) {
            return other.depth_width == config.depth_width && other.depth_height == config.depth_height &&
                   other.color_width == config.color_width && other.color_height == config.color_height &&
                   other.fps == config.fps && other.register_depth_to_color == registered &&
                   other.sync_depth_and_color == synced;
          });
          if (!duplicate) configs_.push_back(config);
        }
      }
    }
  }
}

OpenNI2Sensor::~OpenNI2Sensor() = default;

bool OpenNI2Sensor::SupportsRegistration() const {
  return state_->device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR);
}

bool OpenNI2Sensor::RegistrationEnabled() const {
  return state_->device.getImageRegistrationMode() == openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR;
}

bool OpenNI2Sensor::IsPlayback() const {
  return state_->device.isFile();
}

int OpenNI2Sensor::RecordingFrameCount() const {
  openni::PlaybackControl* playback = state_->device.getPlaybackControl();
  if (!IsPlayback() || playback == nullptr || !state_->depth.isValid()) return 0;
  return playback->getNumberOfFrames(state_->depth);
}

namespace {
// Picks the stream's mode with the given size and fps (depth or colour formats).
bool FindMode(const openni::SensorInfo& sensor, int width, int height, double fps, bool depth, openni::VideoMode* out) {
  const auto& modes = sensor.getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    const bool format_ok = depth ? IsDepthFormat(modes[i].getPixelFormat()) : IsColorFormat(modes[i].getPixelFormat());
    if (format_ok && modes[i].getResolutionX() == width && modes[i].getResolutionY() == height &&
        std::abs(modes[i].getFps() - fps) < 1e-6) {
      *out = modes[i];
      return true;
    }
  }
  return false;
}
}  // namespace

void OpenNI2Sensor::Start(const RgbdStreamConfig& config) {
  ThrowIfInvalid(config, "RGB-D stream config");
  const std::string id = info_.FullId();
  const bool offered = std::any_of(configs_.begin(), configs_.end(), [&](const RgbdStreamConfig& other) {
    return other.depth_width == config.depth_width && other.depth_height == config.depth_height &&
           other.color_width == config.color_width && other.color_height == config.color_height &&
           std::abs(other.fps - config.fps) < 1e-6 && other.register_depth_to_color == config.register_depth_to_color &&
           other.sync_depth_and_color == config.sync_depth_and_color;
  });
  if (!offered) {
    std::ostringstream what;
    what << "the device does not offer depth " << config.depth_width << "x" << config.depth_height << ", colour "
         << config.color_width << "x" << config.color_height << " at " << config.fps << " fps"
         << (config.register_depth_to_color ? " with registration" : "") << " (see SupportedConfigs())";
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, what.str());
  }
  if (streaming_) Stop();
  State& s = *state_;
  const auto fail = [&](const std::string& doing) {
    throw DeviceError(DeviceErrorKind::kIo, id, doing + " failed: " + ExtendedError());
  };
  if (!s.depth.isValid() && s.depth.create(s.device, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    fail("creating the depth stream");
  }
  if (!s.color.isValid() && s.color.create(s.device, openni::SENSOR_COLOR) != openni::STATUS_OK) {
    fail("creating the colour stream");
  }
  if (!IsPlayback()) {
    openni::VideoMode depth_mode, color_mode;
    FindMode(*s.device.getSensorInfo(openni::SENSOR_DEPTH), config.depth_width, config.depth_height, config.fps, true,
             &depth_mode);
    FindMode(*s.device.getSensorInfo(openni::SENSOR_COLOR), config.color_width, config.color_height, config.fps, false,
             &color_mode);
    if (s.depth.setVideoMode(depth_mode) != openni::STATUS_OK) fail("setting the depth video mode");
    if (s.color.setVideoMode(color_mode) != openni::STATUS_OK) fail("setting the colour video mode");
    const openni::ImageRegistrationMode registration =
        config.register_depth_to_color ? openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR : openni::IMAGE_REGISTRATION_OFF;
    if (s.device.setImageRegistrationMode(registration) != openni::STATUS_OK) fail("setting image registration");
  }
  if (s.device.setDepthColorSyncEnabled(config.sync_depth_and_color) != openni::STATUS_OK) {
    fail("setting depth/colour sync");
  }
  if (s.depth.start() != openni::STATUS_OK) fail("starting the depth stream");
  if (s.color.start() != openni::STATUS_OK) fail("starting the colour stream");
  s.registered = RegistrationEnabled();
  s.synced = config.sync_depth_and_color;
  s.last_depth.release();
  s.last_color.release();
  s.have_returned = false;
  streaming_ = true;
}

void OpenNI2Sensor::Stop() {
  if (!streaming_) return;
  StopRecording();
  state_->depth.stop();
  state_->color.stop();
  streaming_ = false;
}

RgbdFrame OpenNI2Sensor::WaitForFrame(Nanoseconds timeout) {
  const std::string id = info_.FullId();
  if (!streaming_) throw InvalidArgumentError(id + ": WaitForFrame before Start");
  State& s = *state_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  openni::VideoStream* streams[2] = {&s.depth, &s.color};
  const auto fresh = [&](const openni::VideoFrameRef& frame) {
    return frame.isValid() && (!s.have_returned || frame.getFrameIndex() > s.last_returned_index);
  };
  while (true) {
    const bool both = fresh(s.last_depth) && fresh(s.last_color);
    if (both && (!s.synced || s.last_depth.getFrameIndex() == s.last_color.getFrameIndex())) break;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      throw DeviceError(DeviceErrorKind::kTimeout, id,
                        "no depth + colour frame pair within the timeout" +
                            std::string(IsPlayback() ? " (or the recording has ended)" : ""));
    }
    int ready = -1;
    const openni::Status status = openni::OpenNI::waitForAnyStream(streams, 2, &ready, static_cast<int>(left.count()));
    if (status == openni::STATUS_TIME_OUT) continue;
    if (status != openni::STATUS_OK || ready < 0) {
      throw DeviceError(DeviceErrorKind::kIo, id, "waiting for frames failed: " + ExtendedError());
    }
    openni::VideoFrameRef& target = ready == 0 ? s.last_depth : s.last_color;
    if (streams[ready]->readFrame(&target) != openni::STATUS_OK) {
      throw DeviceError(DeviceErrorKind::kIo, id, "reading a frame failed: " + ExtendedError());
    }
  }
  const UtcTime host_utc = UtcNow();
  const MonotonicTime host_monotonic = MonotonicNow();
  RgbdFrame out;
  out.device_id = id;
  // Depth.
  {
    const openni::VideoFrameRef& frame = s.last_depth;
    const openni::VideoMode mode = frame.getVideoMode();
    const double scale = mode.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM ? 1e-4 : 1e-3;
    const int width = frame.getWidth();
    const int height = frame.getHeight();
    if (frame.getDataSize() < width * height * 2) {
      throw DeviceError(DeviceErrorKind::kCorruptFrame, id, "depth frame shorter than its size says");
    }
    out.depth_m.create(height, width, CV_32FC1);
    const auto* base = static_cast<const std::uint8_t*>(frame.getData());
    const int stride = frame.getStrideInBytes() > 0 ? frame.getStrideInBytes() : width * 2;
    for (int y = 0; y < height; ++y) {
      const auto* row = reinterpret_cast<const std::uint16_t*>(base + static_cast<std::ptrdiff_t>(y) * stride);
      float* dst = out.depth_m.ptr<float>(y);
      for (int x = 0; x < width; ++x) dst[x] = row[x] == 0 ? NAN : static_cast<float>(row[x] * scale);
    }
    const int x0 = frame.getCroppingEnabled() ? frame.getCropOriginX() : 0;
    const int y0 = frame.getCroppingEnabled() ? frame.getCropOriginY() : 0;
    out.depth_intrinsics = IntrinsicsOf(s.depth, mode.getResolutionX(), mode.getResolutionY(), width, height, x0, y0);
    out.depth_timing.host_utc = host_utc;
    out.depth_timing.host_monotonic = host_monotonic;
    out.depth_timing.device_timestamp = std::chrono::microseconds(frame.getTimestamp());
    out.depth_timing.sequence = static_cast<std::uint64_t>(frame.getFrameIndex());
  }
  // Colour.
  {
    const openni::VideoFrameRef& frame = s.last_color;
    const openni::VideoMode mode = frame.getVideoMode();
    const bool rgb = mode.getPixelFormat() == openni::PIXEL_FORMAT_RGB888;
    const int width = frame.getWidth();
    const int height = frame.getHeight();
    const int bytes = rgb ? 3 : 1;
    if (frame.getDataSize() < width * height * bytes) {
      throw DeviceError(DeviceErrorKind::kCorruptFrame, id, "colour frame shorter than its size says");
    }
    const int stride = frame.getStrideInBytes() > 0 ? frame.getStrideInBytes() : width * bytes;
    const cv::Mat view(height, width, rgb ? CV_8UC3 : CV_8UC1, const_cast<void*>(frame.getData()),
                       static_cast<std::size_t>(stride));
    out.color.pixels = view.clone();
    out.color.layout = rgb ? ColorLayout::kRgb : ColorLayout::kMono;
    out.color.encoding = SampleEncoding::kCameraResponse;
    out.color.bits_per_sample = 8;
    out.color.black_level = 0;
    out.color.white_level = 255;
    const int x0 = frame.getCroppingEnabled() ? frame.getCropOriginX() : 0;
    const int y0 = frame.getCroppingEnabled() ? frame.getCropOriginY() : 0;
    out.color_intrinsics = IntrinsicsOf(s.color, mode.getResolutionX(), mode.getResolutionY(), width, height, x0, y0);
    out.color_timing.host_utc = host_utc;
    out.color_timing.host_monotonic = host_monotonic;
    out.color_timing.device_timestamp = std::chrono::microseconds(frame.getTimestamp());
    out.color_timing.sequence = static_cast<std::uint64_t>(frame.getFrameIndex());
  }
  out.registered_to_color = s.registered;
  if (s.registered) {
    out.depth_intrinsics = out.color_intrinsics;
    out.color_from_depth = Eigen::Isometry3d::Identity();
  } else {
    out.color_from_depth = s.options.color_from_depth;
  }
  s.last_returned_index = std::max(s.last_depth.getFrameIndex(), s.last_color.getFrameIndex());
  s.have_returned = true;
  return out;
}

void OpenNI2Sensor::StartRecording(const std::string& oni_path) {
  const std::string id = info_.FullId();
  if (!streaming_) throw InvalidArgumentError(id + ": start streaming before recording");
  StopRecording();
  State& s = *state_;
  if (s.recorder.create(oni_path.c_str()) != openni::STATUS_OK) {
    throw IoError(oni_path, "OpenNI2 cannot create the recording: " + ExtendedError());
  }
  if (s.recorder.attach(s.depth) != openni::STATUS_OK || s.recorder.attach(s.color) != openni::STATUS_OK ||
      s.recorder.start() != openni::STATUS_OK) {
    s.recorder.destroy();
    throw DeviceError(DeviceErrorKind::kIo, id, "starting the recorder failed: " + ExtendedError());
  }
  s.recording = true;
}

void OpenNI2Sensor::StopRecording() {
  State& s = *state_;
  if (!s.recording) return;
  s.recorder.stop();
  s.recorder.destroy();
  s.recording = false;
}

bool OpenNI2Sensor::recording() const {
  return state_->recording;
}

}  // namespace relume::drivers::openni2
