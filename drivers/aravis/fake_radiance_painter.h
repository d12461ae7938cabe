// Test support: paints frames of Aravis's in-process fake camera ("Fake_1") from a
// sim::TruthSource, so that frames captured through the real Aravis stream carry known,
// checkable radiance. Linked into tests and benchmarks only.
//
// Sensor model (linear, no noise, applied per pixel and channel):
//   counts = black_level + radiance [W m^-2 sr^-1] * exposure [s] * gain * counts_per_radiance_second
//   gain = 10^(GainRaw * raw_gain_db_per_step / 20)
// rounded to the nearest count and clipped at the format's white level (255 or 65535).
// Mono formats see the mean of R, G and B (a flat spectral response); Bayer formats see the
// channel of their colour filter at that pixel; RGB8 sees all three.
// The truth is rendered once per image size at `time` (the analytic sources used here do
// not change with time) and reused for every frame.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <utility>

#include "core/pinhole.h"
#include "core/time.h"
#include "sim/truth.h"

typedef struct _ArvDevice ArvDevice;
typedef struct _ArvBuffer ArvBuffer;

namespace relume::drivers::aravis::testing {

struct FakePainterOptions {
  PinholeIntrinsics intrinsics;  // width/height are replaced by the frame's size
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  UtcTime time{};
  double counts_per_radiance_second = 1000.0;  // counts per (W m^-2 sr^-1 * s) at unit gain
  double raw_gain_db_per_step = 1.0;
  int black_level = 0;
  bool IsValid(std::string* why) const;
};

class FakeRadiancePainter {
 public:
  FakeRadiancePainter(std::shared_ptr<const sim::TruthSource> truth, FakePainterOptions options);
  ~FakeRadiancePainter();
  FakeRadiancePainter(const FakeRadiancePainter&) = delete;
  FakeRadiancePainter& operator=(const FakeRadiancePainter&) = delete;

  // Takes over the fill pattern of the fake camera behind `fake_device` (an ArvFakeDevice,
  // e.g. AravisCamera::native_device() of "Fake_1") until Uninstall() or destruction.
  void Install(ArvDevice* fake_device);
  void Uninstall();

  // The counts the model above gives for `radiance` (one channel) at exposure and raw gain.
  double ExpectedCounts(double radiance, double exposure_time_s, int gain_raw, int white_level) const;
  int frames_painted() const;

 private:
  static void Fill(ArvBuffer* buffer, void* self, unsigned exposure_time_us, unsigned gain_raw, unsigned pixel_format);
  double LinearGain(int gain_raw) const;
  double Counts(double radiance, double exposure_time_s, double gain, int white_level) const;
  const cv::Mat& RadianceFor(int width, int height);  // CV_32FC3, cached per size

  std::shared_ptr<const sim::TruthSource> truth_;
  FakePainterOptions options_;
  void* fake_camera_ = nullptr;  // ArvFakeCamera*, referenced while installed
  mutable std::mutex mutex_;
  std::map<std::pair<int, int>, cv::Mat> radiance_;
  int frames_painted_ = 0;
};

// A fronto-parallel grey wall 2 m in front of the camera whose radiance varies linearly
// across the image: L(u, v) = base + per_column * (u + 0.5) + per_row * (v + 0.5), equal in
// R, G and B. All other truth layers follow sim/truth.h for that wall (albedo 0.5).
class RadianceRampTruth : public sim::TruthSource {
 public:
  RadianceRampTruth(double base, double per_column, double per_row)
      : base_(base), per_column_(per_column), per_row_(per_row) {}
  sim::GroundTruth Render(const PinholeCamera& camera, UtcTime time) const override;
  double RadianceAt(double u_centre, double v_centre) const {
    return base_ + per_column_ * u_centre + per_row_ * v_centre;
  }

 private:
  double base_, per_column_, per_row_;
};

}  // namespace relume::drivers::aravis::testing
