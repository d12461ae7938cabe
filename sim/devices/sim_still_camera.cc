#include "sim/devices/sim_still_camera.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/device_error.h"
#include "sim/devices/random.h"

namespace relume::sim {

using drivers::DeviceError;
using drivers::DeviceErrorKind;
using drivers::ExposureControl;

SimStillCameraOptions SimStillCameraOptions::ForControl(ExposureControl control) {
  SimStillCameraOptions options;
  options.control = control;
  options.capabilities = DefaultCapabilities(control);
  if (control == ExposureControl::kContinuous) {
    options.initial_exposure = {1.0 / 100, 4.0, 100.0, 0.0};
    options.model.raw_bits = 12;
    options.model.response = ResponseCurve::Linear();
  }
  return options;
}

bool SimStillCameraOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  std::string reason;
  if (!model.IsValid(&reason)) return fail("camera model: " + reason);
  if (!initial_exposure.IsValid(&reason)) return fail("initial_exposure: " + reason);
  if (!device_clock.IsValid(&reason)) return fail(reason);
  if (control == ExposureControl::kEvOnly && !metering.IsValid(&reason)) return fail(reason);
  if (capabilities.control != control) return fail("capabilities are for another exposure control mode");
  if (control == ExposureControl::kShutterList && capabilities.shutter_speeds_s.empty())
    return fail("a shutter-list camera needs shutter speeds");
  if (control == ExposureControl::kContinuous &&
      !(capabilities.min_exposure_time_s > 0.0 && capabilities.max_exposure_time_s >= capabilities.min_exposure_time_s))
    return fail("a continuous-exposure camera needs 0 < min_exposure_time_s <= max_exposure_time_s");
  if (control == ExposureControl::kEvOnly && capabilities.ev_steps.empty())
    return fail("an EV-only camera needs EV steps");
  if (!(std::isfinite(readout_time_s) && readout_time_s >= 0.0)) return fail("readout_time_s must be >= 0");
  if (sensor_temperature_c && !std::isfinite(*sensor_temperature_c)) return fail("sensor_temperature_c must be finite");
  return true;
}

SimStillCamera::SimStillCamera(drivers::DeviceInfo info, SimStillCameraOptions options, PinholeCamera camera,
                               std::shared_ptr<const TruthSource> truth, std::shared_ptr<Clock> clock,
                               std::shared_ptr<DeviceLink> link)
    : info_(std::move(info)),
      options_(std::move(options)),
      camera_(camera),
      truth_(std::move(truth)),
      clock_(std::move(clock)),
      link_(std::move(link)) {
  RELUME_CHECK(truth_ != nullptr && clock_ != nullptr);
  ThrowIfInvalid(options_, ("simulated camera " + info_.FullId()).c_str());
  ThrowIfInvalid(camera_.intrinsics, ("simulated camera " + info_.FullId() + " intrinsics").c_str());
  if (!link_) link_ = std::make_shared<DeviceLink>(FaultPlan{}, clock_);
  if (!link_->Present()) throw DeviceError(DeviceErrorKind::kNotFound, info_.FullId(), "the device is unplugged");
  if (!link_->TryClaim())
    throw DeviceError(DeviceErrorKind::kAccessDenied, info_.FullId(),
                      "already opened by another handle; close it first");
  generation_ = link_->generation();
  exposure_ = options_.initial_exposure;
}

SimStillCamera::~SimStillCamera() {
  link_->Release();
}

void SimStillCamera::ThrowIfGone() const {
  if (link_->generation() != generation_)
    throw DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(),
                      "the camera was unplugged; reopen it when it is enumerated again");
}

drivers::ExposureCapabilities SimStillCamera::capabilities() const {
  ThrowIfGone();
  return options_.capabilities;
}

void SimStillCamera::Apply(const drivers::ExposureSettings& settings) {
  ThrowIfGone();
  ValidateSettings(options_.capabilities, settings, info_.FullId());  // throws before any change
  if (settings.exposure_time_s) exposure_.exposure_time_s = *settings.exposure_time_s;
  if (settings.ev_compensation) ev_compensation_ = *settings.ev_compensation;
  if (settings.aperture_f) exposure_.aperture_f = *settings.aperture_f;
  if (settings.iso) exposure_.iso = *settings.iso;
  if (settings.gain_db) exposure_.gain_db = *settings.gain_db;
}

drivers::StillFrame SimStillCamera::Capture() {
  ThrowIfGone();
  const auto [frame_number, faults] = link_->NextFrame();
  const std::string id = info_.FullId();
  if (faults.disconnect) {
    link_->Unplug();
    throw DeviceError(DeviceErrorKind::kDisconnected, id,
                      "USB device disconnected during capture of frame " + std::to_string(frame_number));
  }
  if (faults.timeout) {
    clock_->SleepFor(
        std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(link_->plan().timeout_duration_s)));
    throw DeviceError(DeviceErrorKind::kTimeout, id, "no answer to capture request " + std::to_string(frame_number));
  }
  if (faults.busy) throw DeviceError(DeviceErrorKind::kBusy, id, "PTP device busy");

  const UtcTime start_utc = clock_->NowUtc();
  const MonotonicTime start_monotonic = clock_->NowMonotonic();
  const GroundTruth truth = truth_->Render(camera_, start_utc);
  ExposureParams exposure = exposure_;
  if (options_.control == ExposureControl::kEvOnly) {
    const MeteringResult metered =
        MeterExposure(truth.radiance, camera_.intrinsics, exposure, options_.model, options_.metering);
    exposure.exposure_time_s = metered.exposure_time_s * std::exp2(ev_compensation_);
  }
  cv::Mat electrons = ExpectedElectrons(truth.radiance, camera_.intrinsics, exposure, options_.model);
  if (options_.add_noise)
    electrons = AddSensorNoise(electrons, options_.model, StreamSeed(options_.model.noise_seed, frame_number));

  drivers::StillFrame frame;
  frame.device_id = id;
  frame.model = info_.model;
  frame.image = options_.output == SimStillCameraOptions::Output::kRaw
                    ? RawFromElectrons(electrons, exposure, options_.model)
                    : EncodedFromElectrons(electrons, exposure, options_.model);
  frame.original_file = EncodeCameraFile(frame.image, &frame.original_format);
  clock_->SleepFor(std::chrono::duration_cast<Nanoseconds>(
      std::chrono::duration<double>(exposure.exposure_time_s + options_.readout_time_s)));
  TransferAndCheck(frame.original_file, faults, link_->plan().seed, frame_number, id);

  const drivers::ExposureCapabilities& caps = options_.capabilities;
  frame.exposure.exposure_time_s = options_.control == ExposureControl::kEvOnly ? NAN : exposure.exposure_time_s;
  frame.exposure.ev_compensation = options_.control == ExposureControl::kEvOnly ? ev_compensation_ : 0.0;
  frame.exposure.aperture_f = exposure.aperture_f;
  frame.exposure.iso = caps.iso_values.empty() && options_.control == ExposureControl::kContinuous ? NAN : exposure.iso;
  frame.exposure.gain_db = caps.max_gain_db > caps.min_gain_db ? exposure.gain_db : NAN;
  frame.timing.host_utc = clock_->NowUtc();
  frame.timing.host_monotonic = clock_->NowMonotonic();
  frame.timing.device_timestamp = options_.device_clock.DeviceTime(start_monotonic, link_->clock_jumps());
  frame.timing.sequence = frame_number;
  frame.sensor_temperature_c = options_.sensor_temperature_c;
  return frame;
}

std::vector<std::uint8_t> EncodeCameraFile(const CameraImage& image, std::string* format) {
  cv::Mat file_order = image.pixels;
  if (image.pixels.channels() == 3) {
    file_order = cv::Mat(image.pixels.size(), image.pixels.type());  // new storage: never swap in place
    const int from_to[] = {0, 2, 1, 1, 2, 0};
    cv::mixChannels(&image.pixels, 1, &file_order, 1, from_to, 3);
  }
  const bool raw = image.encoding == SampleEncoding::kSensorLinear;
  const std::string extension = raw ? ".tiff" : ".png";
  std::vector<std::uint8_t> bytes;
  try {
    if (!cv::imencode(extension, file_order, bytes)) throw IoError(extension, "OpenCV could not encode the frame");
  } catch (const cv::Exception& e) {
    throw IoError(extension, std::string("OpenCV could not encode the frame: ") + e.what());
  }
  if (format) *format = raw ? "tiff" : "png";
  return bytes;
}

}  // namespace relume::sim
