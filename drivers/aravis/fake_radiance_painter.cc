#include "drivers/aravis/fake_radiance_painter.h"

extern "C" {
#include <arv.h>
}

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "drivers/aravis/pixel_formats.h"

namespace relume::drivers::aravis::testing {
namespace {

// Which colour channel (0 R, 1 G, 2 B) a Bayer pixel sees.
int BayerChannel(ColorLayout layout, int x, int y) {
  const int cell = (y % 2) * 2 + (x % 2);  // 0 top-left, 1 top-right, 2 bottom-left, 3 bottom-right
  switch (layout) {
    case ColorLayout::kBayerRggb: return cell == 0 ? 0 : (cell == 3 ? 2 : 1);
    case ColorLayout::kBayerBggr: return cell == 0 ? 2 : (cell == 3 ? 0 : 1);
    case ColorLayout::kBayerGrbg: return cell == 1 ? 0 : (cell == 2 ? 2 : 1);
    case ColorLayout::kBayerGbrg: return cell == 1 ? 2 : (cell == 2 ? 0 : 1);
    default: return 1;
  }
}

}  // namespace

bool FakePainterOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(counts_per_radiance_second) && counts_per_radiance_second > 0.0)) {
    if (why) *why = "counts_per_radiance_second must be positive";
    return false;
  }
  if (!std::isfinite(raw_gain_db_per_step) || black_level < 0) {
    if (why) *why = "raw_gain_db_per_step must be finite and black_level >= 0";
    return false;
  }
  return true;
}

FakeRadiancePainter::FakeRadiancePainter(std::shared_ptr<const sim::TruthSource> truth, FakePainterOptions options)
    : truth_(std::move(truth)), options_(std::move(options)) {
  RELUME_CHECK(truth_ != nullptr);
  ThrowIfInvalid(options_, "FakePainterOptions");
}

FakeRadiancePainter::~FakeRadiancePainter() {
  Uninstall();
}

void FakeRadiancePainter::Install(ArvDevice* fake_device) {
  RELUME_CHECK_MSG(fake_device != nullptr && g_type_check_instance_is_a(reinterpret_cast<GTypeInstance*>(fake_device),
                                                                        arv_fake_device_get_type()),
                   "FakeRadiancePainter needs Aravis's in-process fake device");
  Uninstall();
  ArvFakeCamera* camera = arv_fake_device_get_fake_camera(reinterpret_cast<ArvFakeDevice*>(fake_device));
  RELUME_CHECK(camera != nullptr);
  g_object_ref(camera);
  fake_camera_ = camera;
  arv_fake_camera_set_fill_pattern(camera, &FakeRadiancePainter::Fill, this);
}

void FakeRadiancePainter::Uninstall() {
  if (fake_camera_ == nullptr) return;
  auto* camera = static_cast<ArvFakeCamera*>(fake_camera_);
  arv_fake_camera_set_fill_pattern(camera, nullptr, nullptr);  // back to Aravis's ramp
  g_object_unref(camera);
  fake_camera_ = nullptr;
}

int FakeRadiancePainter::frames_painted() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_painted_;
}

double FakeRadiancePainter::LinearGain(int gain_raw) const {
  return std::pow(10.0, gain_raw * options_.raw_gain_db_per_step / 20.0);
}

double FakeRadiancePainter::Counts(double radiance, double exposure_time_s, double gain, int white_level) const {
  const double counts = options_.black_level + radiance * exposure_time_s * gain * options_.counts_per_radiance_second;
  return std::clamp(std::round(counts), 0.0, static_cast<double>(white_level));
}

double FakeRadiancePainter::ExpectedCounts(double radiance, double exposure_time_s, int gain_raw,
                                           int white_level) const {
  return Counts(radiance, exposure_time_s, LinearGain(gain_raw), white_level);
}

const cv::Mat& FakeRadiancePainter::RadianceFor(int width, int height) {
  auto it = radiance_.find({width, height});
  if (it != radiance_.end()) return it->second;
  PinholeCamera camera;
  camera.intrinsics = options_.intrinsics;
  if (camera.intrinsics.width != width || camera.intrinsics.height != height || camera.intrinsics.fx <= 0.0) {
    camera.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, 60.0 * M_PI / 180.0);
  }
  camera.world_from_camera = options_.world_from_camera;
  const sim::GroundTruth truth = truth_->Render(camera, options_.time);
  RELUME_CHECK(truth.radiance.pixels.type() == CV_32FC3 && truth.radiance.width() == width &&
               truth.radiance.height() == height);
  return radiance_.emplace(std::make_pair(width, height), truth.radiance.pixels.clone()).first->second;
}

void FakeRadiancePainter::Fill(ArvBuffer* buffer, void* self_ptr, unsigned exposure_time_us, unsigned gain_raw,
                               unsigned pixel_format) {
  auto* self = static_cast<FakeRadiancePainter*>(self_ptr);
  const std::optional<PixelFormatInfo> format = FindPixelFormat(pixel_format);
  if (!format) return;  // leaves the buffer as it is: the test sees the wrong format
  const int width = arv_buffer_get_image_width(buffer);
  const int height = arv_buffer_get_image_height(buffer);
  auto* data = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
  std::lock_guard<std::mutex> lock(self->mutex_);
  const cv::Mat& radiance = self->RadianceFor(width, height);
  const double exposure_s = exposure_time_us * 1e-6;
  const int white = (1 << format->bits_per_sample) - 1;
  const int channels = ChannelCount(format->layout);
  const double gain = self->LinearGain(static_cast<int>(gain_raw));  // once per frame
  for (int y = 0; y < height; ++y) {
    const auto* row = radiance.ptr<cv::Vec3f>(y);
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < channels; ++c) {
        double value = 0.0;
        if (format->layout == ColorLayout::kMono) {
          value = (row[x][0] + row[x][1] + row[x][2]) / 3.0;
        } else if (format->layout == ColorLayout::kRgb) {
          const bool bgr = pixel_format == 0x02180015u;
          value = row[x][bgr ? 2 - c : c];
        } else {
          value = row[x][BayerChannel(format->layout, x, y)];
        }
        const auto counts = static_cast<std::uint32_t>(self->Counts(value, exposure_s, gain, white));
        const std::size_t index = (static_cast<std::size_t>(y) * width + x) * channels + c;
        if (format->bytes_per_pixel / channels == 2) {
          const auto v16 = static_cast<std::uint16_t>(counts);
          std::memcpy(data + 2 * index, &v16, 2);  // little-endian host, as GenICam unpacked formats
        } else {
          data[index] = static_cast<std::uint8_t>(counts);
        }
      }
    }
  }
  ++self->frames_painted_;
}

sim::GroundTruth RadianceRampTruth::Render(const PinholeCamera& camera, UtcTime /*time*/) const {
  const int w = camera.intrinsics.width;
  const int h = camera.intrinsics.height;
  constexpr double kWallDistanceM = 2.0;
  constexpr float kAlbedo = 0.5f;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  sim::GroundTruth truth;
  truth.radiance = MakeRadianceImage(w, h, RadianceUnit::kWattsPerSqmPerSr);
  truth.depth_m = cv::Mat(h, w, CV_32FC1, cv::Scalar(kWallDistanceM));
  const Eigen::Vector3d normal = camera.world_from_camera.linear() * Eigen::Vector3d(0, 0, -1);
  truth.normal_in_world = cv::Mat(h, w, CV_32FC3, cv::Scalar(normal.x(), normal.y(), normal.z()));
  truth.albedo = cv::Mat(h, w, CV_32FC3, cv::Scalar(kAlbedo, kAlbedo, kAlbedo));
  truth.sun_visibility = cv::Mat(h, w, CV_32FC1, cv::Scalar(0.0));
  truth.irradiance = cv::Mat(h, w, CV_32FC3, cv::Scalar(nan, nan, nan));
  truth.object_id = cv::Mat(h, w, CV_32SC1, cv::Scalar(0));
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const auto l = static_cast<float>(RadianceAt(u + 0.5, v + 0.5));
      truth.radiance.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f(l, l, l);
      const float e = static_cast<float>(M_PI) * l / kAlbedo;  // Lambertian: L = albedo * E / pi
      truth.irradiance.at<cv::Vec3f>(v, u) = cv::Vec3f(e, e, e);
    }
  }
  return truth;
}

}  // namespace relume::drivers::aravis::testing
