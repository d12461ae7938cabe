// A simulated RGB-D sensor as an OpenNI2 driver, built on OpenNI2's public driver API
// (openni2/Driver/OniDriverAPI.h). libOpenNI2 loads it like the PrimeSense and Dummy drivers
// when it sits in the OpenNI2/Drivers folder beside libOpenNI2.so.0, so relume's OpenNI2 backend
// is tested through the real library without hardware.
//
// Conventions:
//  - Device URI "relume-sim://rgbd/<n>"; RELUME_SIM_RGBD_DEVICES (read at OpenNI initialise)
//    sets how many devices appear (default 1; 0 simulates "no sensor attached").
//  - Streams: depth (DEPTH_1_MM) and colour (RGB888), 640x480 or 320x240 at 30 fps, rendering
//    the analytic scene of sim_scene.h. Depth is rendered from the depth camera, or from the
//    colour camera when image registration is DEPTH_TO_COLOR (an ideal registration).
//  - Properties: video mode, cropping, horizontal/vertical FOV, max/min value (10000 / 0 mm),
//    mirroring (off; cannot be turned on), stride; device: image registration, serial number.
//  - One producer thread per device makes depth and colour frames of the same index and
//    timestamp (the device clock, microseconds since the device was opened), so depth/colour
//    frame sync is exact. The thread is joined when the last stream stops and on close.
#include <OniCProperties.h>
#include <OniCTypes.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

// ONI_EXPORT_DRIVER allocates with XnLib's macros, which the Debian package does not install.
#define XN_NEW(type, arg) new type(arg)
#define XN_DELETE(p) delete (p)
#include <Driver/OniDriverAPI.h>

#include "drivers/openni2/simdriver/sim_scene.h"

namespace relume::drivers::openni2_sim {
namespace {

constexpr int kMaxDepthMm = 10000;
constexpr int kFps = 30;

OniVideoMode Mode(OniPixelFormat format, int width, int height) {
  OniVideoMode mode;
  mode.pixelFormat = format;
  mode.resolutionX = width;
  mode.resolutionY = height;
  mode.fps = kFps;
  return mode;
}

class SimDevice;

class SimStream : public oni::driver::StreamBase {
 public:
  SimStream(OniSensorType type, SimDevice* device)
      : type_(type),
        device_(device),
        mode_(Mode(type == ONI_SENSOR_DEPTH ? ONI_PIXEL_FORMAT_DEPTH_1_MM : ONI_PIXEL_FORMAT_RGB888, 640, 480)) {
    std::memset(&cropping_, 0, sizeof(cropping_));
  }

  OniStatus start() override;
  void stop() override;

  int getRequiredFrameSize() override { return mode_.resolutionX * mode_.resolutionY * BytesPerPixel(); }

  OniBool isPropertySupported(int id) override {
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE:
      case ONI_STREAM_PROPERTY_CROPPING:
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
      case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      case ONI_STREAM_PROPERTY_MIRRORING:
      case ONI_STREAM_PROPERTY_STRIDE: return TRUE;
      case ONI_STREAM_PROPERTY_MAX_VALUE:
      case ONI_STREAM_PROPERTY_MIN_VALUE: return type_ == ONI_SENSOR_DEPTH ? TRUE : FALSE;
      default: return FALSE;
    }
  }

  OniStatus getProperty(int id, void* data, int* size) override;
  OniStatus setProperty(int id, const void* data, int size) override;

  // Renders and delivers one frame (called by the device's producer thread).
  void Produce(int frame_index, std::uint64_t timestamp_us, bool registered);

  OniSensorType type() const { return type_; }
  bool running() const { return running_; }

 private:
  int BytesPerPixel() const { return type_ == ONI_SENSOR_DEPTH ? 2 : 3; }
  double Focal() const { return (mode_.resolutionX / 2.0) / std::tan(kHorizontalFovRad / 2.0); }

  OniSensorType type_;
  SimDevice* device_;
  OniVideoMode mode_;
  OniCropping cropping_;
  std::atomic<bool> running_{false};
};

class SimDevice : public oni::driver::DeviceBase {
 public:
  explicit SimDevice(const OniDeviceInfo& info) : info_(info), opened_(std::chrono::steady_clock::now()) {
    depth_modes_ = {Mode(ONI_PIXEL_FORMAT_DEPTH_1_MM, 640, 480), Mode(ONI_PIXEL_FORMAT_DEPTH_1_MM, 320, 240)};
    color_modes_ = {Mode(ONI_PIXEL_FORMAT_RGB888, 640, 480), Mode(ONI_PIXEL_FORMAT_RGB888, 320, 240)};
    sensors_[0] = {ONI_SENSOR_DEPTH, static_cast<int>(depth_modes_.size()), depth_modes_.data()};
    sensors_[1] = {ONI_SENSOR_COLOR, static_cast<int>(color_modes_.size()), color_modes_.data()};
  }
  ~SimDevice() override { StopThread(); }

  OniStatus getSensorInfoList(OniSensorInfo** infos, int* count) override {
    *infos = sensors_;
    *count = 2;
    return ONI_STATUS_OK;
  }

  oni::driver::StreamBase* createStream(OniSensorType type) override {
    if (type != ONI_SENSOR_DEPTH && type != ONI_SENSOR_COLOR) return nullptr;
    std::lock_guard<std::mutex> lock(mutex_);
    auto* stream = new (std::nothrow) SimStream(type, this);
    if (stream != nullptr) streams_.push_back(stream);
    return stream;
  }

  void destroyStream(oni::driver::StreamBase* base) override {
    auto* stream = static_cast<SimStream*>(base);
    stream->stop();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      streams_.erase(std::remove(streams_.begin(), streams_.end(), stream), streams_.end());
    }
    delete stream;
  }

  OniBool isImageRegistrationModeSupported(OniImageRegistrationMode mode) override {
    return mode == ONI_IMAGE_REGISTRATION_OFF || mode == ONI_IMAGE_REGISTRATION_DEPTH_TO_COLOR ? TRUE : FALSE;
  }

  OniBool isPropertySupported(int id) override {
    return id == ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION || id == ONI_DEVICE_PROPERTY_SERIAL_NUMBER ||
                   id == ONI_DEVICE_PROPERTY_DRIVER_VERSION
               ? TRUE
               : FALSE;
  }

  OniStatus getProperty(int id, void* data, int* size) override {
    switch (id) {
      case ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION: {
        if (*size != sizeof(OniImageRegistrationMode)) return ONI_STATUS_BAD_PARAMETER;
        *static_cast<OniImageRegistrationMode*>(data) =
            registered_ ? ONI_IMAGE_REGISTRATION_DEPTH_TO_COLOR : ONI_IMAGE_REGISTRATION_OFF;
        return ONI_STATUS_OK;
      }
      case ONI_DEVICE_PROPERTY_SERIAL_NUMBER: {
        const std::string serial = std::string("SIMRGBD") + info_.uri[std::strlen(info_.uri) - 1];
        if (*size < static_cast<int>(serial.size()) + 1) return ONI_STATUS_BAD_PARAMETER;
        std::memcpy(data, serial.c_str(), serial.size() + 1);
        *size = static_cast<int>(serial.size()) + 1;
        return ONI_STATUS_OK;
      }
      case ONI_DEVICE_PROPERTY_DRIVER_VERSION: {
        if (*size != sizeof(OniVersion)) return ONI_STATUS_BAD_PARAMETER;
        *static_cast<OniVersion*>(data) = OniVersion{1, 0, 0, 0};
        return ONI_STATUS_OK;
      }
      default: return ONI_STATUS_NOT_SUPPORTED;
    }
  }

  OniStatus setProperty(int id, const void* data, int size) override {
    if (id != ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION) return ONI_STATUS_NOT_SUPPORTED;
    if (size != sizeof(OniImageRegistrationMode)) return ONI_STATUS_BAD_PARAMETER;
    const OniImageRegistrationMode mode = *static_cast<const OniImageRegistrationMode*>(data);
    if (!isImageRegistrationModeSupported(mode)) return ONI_STATUS_NOT_SUPPORTED;
    registered_ = mode == ONI_IMAGE_REGISTRATION_DEPTH_TO_COLOR;
    return ONI_STATUS_OK;
  }

  // Called by streams when they start or stop: the producer thread runs while any stream does.
  void StreamStateChanged() {
    bool any = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (SimStream* stream : streams_) any = any || stream->running();
    }
    if (any && !thread_.joinable()) {
      quit_ = false;
      thread_ = std::thread([this] { Run(); });
    } else if (!any) {
      StopThread();
    }
  }

  const std::vector<OniVideoMode>& modes(OniSensorType type) const {
    return type == ONI_SENSOR_DEPTH ? depth_modes_ : color_modes_;
  }

 private:
  void StopThread() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
  }

  void Run() {
    const auto period = std::chrono::microseconds(1000000 / kFps);
    auto next = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(mutex_);
    while (!quit_) {
      const auto now = std::chrono::steady_clock::now();
      const std::uint64_t timestamp_us =
          static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(now - opened_).count());
      ++frame_index_;
      for (SimStream* stream : streams_) {
        if (stream->running()) stream->Produce(frame_index_, timestamp_us, registered_);
      }
      next += period;
      wake_.wait_until(lock, next, [this] { return quit_; });
    }
  }

  OniDeviceInfo info_;
  std::chrono::steady_clock::time_point opened_;
  std::vector<OniVideoMode> depth_modes_;
  std::vector<OniVideoMode> color_modes_;
  OniSensorInfo sensors_[2];
  std::mutex mutex_;
  std::condition_variable wake_;
  std::thread thread_;
  bool quit_ = false;
  int frame_index_ = 0;
  std::atomic<bool> registered_{false};
  std::vector<SimStream*> streams_;
};

OniStatus SimStream::start() {
  running_ = true;
  device_->StreamStateChanged();
  return ONI_STATUS_OK;
}

void SimStream::stop() {
  if (!running_) return;
  running_ = false;
  device_->StreamStateChanged();
}

template <typename T>
OniStatus Put(void* data, int* size, const T& value) {
  if (*size != static_cast<int>(sizeof(T))) return ONI_STATUS_BAD_PARAMETER;
  std::memcpy(data, &value, sizeof(T));
  return ONI_STATUS_OK;
}

OniStatus SimStream::getProperty(int id, void* data, int* size) {
  switch (id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE: return Put(data, size, mode_);
    case ONI_STREAM_PROPERTY_CROPPING: return Put(data, size, cropping_);
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV: return Put(data, size, static_cast<float>(kHorizontalFovRad));
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      return Put(data, size, static_cast<float>(2.0 * std::atan((mode_.resolutionY / 2.0) / Focal())));
    case ONI_STREAM_PROPERTY_MIRRORING: return Put(data, size, static_cast<OniBool>(FALSE));
    case ONI_STREAM_PROPERTY_STRIDE:
      return Put(data, size, (cropping_.enabled ? cropping_.width : mode_.resolutionX) * BytesPerPixel());
    case ONI_STREAM_PROPERTY_MAX_VALUE:
      if (type_ != ONI_SENSOR_DEPTH) return ONI_STATUS_NOT_SUPPORTED;
      return Put(data, size, kMaxDepthMm);
    case ONI_STREAM_PROPERTY_MIN_VALUE:
      if (type_ != ONI_SENSOR_DEPTH) return ONI_STATUS_NOT_SUPPORTED;
      return Put(data, size, 0);
    default: return ONI_STATUS_NOT_SUPPORTED;
  }
}

OniStatus SimStream::setProperty(int id, const void* data, int size) {
  switch (id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE: {
      if (size != sizeof(OniVideoMode)) return ONI_STATUS_BAD_PARAMETER;
      const OniVideoMode& wanted = *static_cast<const OniVideoMode*>(data);
      for (const OniVideoMode& mode : device_->modes(type_)) {
        if (mode.pixelFormat == wanted.pixelFormat && mode.resolutionX == wanted.resolutionX &&
            mode.resolutionY == wanted.resolutionY && mode.fps == wanted.fps) {
          if (running_) return ONI_STATUS_OUT_OF_FLOW;
          mode_ = mode;
          std::memset(&cropping_, 0, sizeof(cropping_));
          return ONI_STATUS_OK;
        }
      }
      return ONI_STATUS_NOT_SUPPORTED;
    }
    case ONI_STREAM_PROPERTY_CROPPING: {
      if (size != sizeof(OniCropping)) return ONI_STATUS_BAD_PARAMETER;
      const OniCropping& wanted = *static_cast<const OniCropping*>(data);
      if (wanted.enabled &&
          (wanted.originX < 0 || wanted.originY < 0 || wanted.width <= 0 || wanted.height <= 0 ||
           wanted.originX + wanted.width > mode_.resolutionX || wanted.originY + wanted.height > mode_.resolutionY)) {
        return ONI_STATUS_BAD_PARAMETER;
      }
      cropping_ = wanted;
      return ONI_STATUS_OK;
    }
    case ONI_STREAM_PROPERTY_MIRRORING: {
      if (size != sizeof(OniBool)) return ONI_STATUS_BAD_PARAMETER;
      return *static_cast<const OniBool*>(data) ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    default: return ONI_STATUS_NOT_SUPPORTED;
  }
}

void SimStream::Produce(int frame_index, std::uint64_t timestamp_us, bool registered) {
  OniFrame* frame = getServices().acquireFrame();
  if (frame == nullptr) return;
  const int width = mode_.resolutionX;
  const int height = mode_.resolutionY;
  const bool crop = cropping_.enabled != 0;
  const int x0 = crop ? cropping_.originX : 0;
  const int y0 = crop ? cropping_.originY : 0;
  const int out_w = crop ? cropping_.width : width;
  const int out_h = crop ? cropping_.height : height;
  frame->sensorType = type_;
  frame->timestamp = timestamp_us;
  frame->frameIndex = frame_index;
  frame->videoMode = mode_;
  frame->width = out_w;
  frame->height = out_h;
  frame->croppingEnabled = crop ? TRUE : FALSE;
  frame->cropOriginX = x0;
  frame->cropOriginY = y0;
  frame->stride = out_w * BytesPerPixel();
  frame->dataSize = out_w * out_h * BytesPerPixel();
  const double origin_x = type_ == ONI_SENSOR_DEPTH && !registered ? kDepthCameraXInColor : 0.0;
  const double light[3] = {-1.0 / std::sqrt(3.0), -1.0 / std::sqrt(3.0), -1.0 / std::sqrt(3.0)};
  for (int y = 0; y < out_h; ++y) {
    for (int x = 0; x < out_w; ++x) {
      const std::optional<Hit> hit = Trace(x + x0, y + y0, width, height, origin_x);
      const int i = y * out_w + x;
      if (type_ == ONI_SENSOR_DEPTH) {
        std::uint16_t depth_mm = 0;
        if (hit) {
          const long mm = std::lround(hit->depth_z * 1000.0);
          depth_mm = mm > 0 && mm <= kMaxDepthMm ? static_cast<std::uint16_t>(mm) : 0;
        }
        static_cast<std::uint16_t*>(frame->data)[i] = depth_mm;
      } else {
        OniRGB888Pixel& pixel = static_cast<OniRGB888Pixel*>(frame->data)[i];
        pixel = {0, 0, 0};
        if (hit && hit->sphere) {
          // n . l with l pointing from the light towards the scene: use -l for the lit side.
          const double lit =
              std::max(0.0, -(hit->normal[0] * light[0] + hit->normal[1] * light[1] + hit->normal[2] * light[2]));
          const double k = 0.3 + 0.7 * lit;
          pixel = {static_cast<std::uint8_t>(std::lround(200 * k)), static_cast<std::uint8_t>(std::lround(60 * k)),
                   static_cast<std::uint8_t>(std::lround(40 * k))};
        } else if (hit) {
          const long cx = static_cast<long>(std::floor(hit->point[0] / 0.1));
          const long cy = static_cast<long>(std::floor(hit->point[1] / 0.1));
          const std::uint8_t value = ((cx + cy) % 2 == 0) ? 220 : 40;
          pixel = {value, value, value};
        }
      }
    }
  }
  raiseNewFrame(frame);
  getServices().releaseFrame(frame);
}

class SimDriver : public oni::driver::DriverBase {
 public:
  explicit SimDriver(OniDriverServices* services) : DriverBase(services) {}

  OniStatus initialize(oni::driver::DeviceConnectedCallback connected,
                       oni::driver::DeviceDisconnectedCallback disconnected,
                       oni::driver::DeviceStateChangedCallback state_changed, void* cookie) override {
    const OniStatus status = DriverBase::initialize(connected, disconnected, state_changed, cookie);
    if (status != ONI_STATUS_OK) return status;
    int count = 1;
    if (const char* text = std::getenv("RELUME_SIM_RGBD_DEVICES")) count = std::max(0, std::atoi(text));
    for (int i = 0; i < count; ++i) {
      OniDeviceInfo info;
      std::memset(&info, 0, sizeof(info));
      std::snprintf(info.uri, sizeof(info.uri), "relume-sim://rgbd/%d", i);
      std::snprintf(info.vendor, sizeof(info.vendor), "relume");
      std::snprintf(info.name, sizeof(info.name), "Simulated RGB-D");
      devices_.push_back(info);
      deviceConnected(&devices_.back());
    }
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase* deviceOpen(const char* uri, const char* /*mode*/) override {
    for (const OniDeviceInfo& info : devices_) {
      if (std::strcmp(info.uri, uri) == 0) return new (std::nothrow) SimDevice(info);
    }
    getServices().errorLoggerAppend("relume sim driver: no device '%s'", uri);
    return nullptr;
  }

  void deviceClose(oni::driver::DeviceBase* device) override { delete device; }

  OniStatus tryDevice(const char* uri) override {
    return std::strncmp(uri, "relume-sim://", 13) == 0 ? ONI_STATUS_OK : ONI_STATUS_ERROR;
  }

  // The device produces depth and colour frames with equal indices and timestamps, so any
  // non-null handle will do: there is nothing to align.
  void* enableFrameSync(oni::driver::StreamBase** /*streams*/, int /*count*/) override { return &sync_handle_; }
  void disableFrameSync(void* /*handle*/) override {}

  void shutdown() override { devices_.clear(); }

 private:
  std::vector<OniDeviceInfo> devices_;
  int sync_handle_ = 0;
};

}  // namespace
}  // namespace relume::drivers::openni2_sim

ONI_EXPORT_DRIVER(relume::drivers::openni2_sim::SimDriver)
