// RGB-D recorder throughput (issue 4): can the recorder store 640x480 depth + colour at 30 fps
// without dropping frames? The recorder is under test, not the renderer: the simulated sensor
// renders only ~5 frames/s at 640x480 on a 2-core machine, so frames are rendered once up
// front (4 frames of SimRgbdSensor, the analytic wall-and-sphere scene, noise on) and a PacedRgbdSource
// delivers them in turn at a real 30 fps on the host clock, like a sensor with a 4-frame
// buffer: a frame not taken within 4 periods is lost (counted as dropped by the device).
//
// The recorder's options are the defaults (64-frame queue, group commits of up to 8 frames);
// arg 0 = rgbd_batch_frames, so /1 is the one-frame-per-commit writer for comparison; arg 1 =
// the session's RGB-D file format (0 = zstd TIFF, the default; 1 = PNG).
//
// Counters: frames delivered, dropped (by the recorder's queue + by the device buffer),
// stored, disk bytes/s (what the session writer wrote, per wall second) and the per-frame
// latency from arrival at the recorder to acknowledgement (queue wait + encode + fsyncs +
// SQLite commit), p50/p90/p99/max in ms.
// Stream length: RELUME_RGBD_STREAM_SECONDS (default 3 s, for the ctest smoke run; the
// documented figures are from a 300 s run). Sessions go to RELUME_BENCHMARK_DIR or $TMPDIR.
// Run: RELUME_RGBD_STREAM_SECONDS=300 build/release/capture/rgbd_recorder_benchmark
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "capture/recorder.h"
#include "capture/tiff_codec.h"
#include "drivers/device_error.h"
#include "sim/devices/sim_rgbd_sensor.h"
#include "sim/devices/test_rig.h"

namespace relume::capture {
namespace {

namespace fs = std::filesystem;
using SteadyClock = std::chrono::steady_clock;

// Delivers pre-rendered frames at `fps` in real time, with fresh host timestamps and
// sequence numbers; slots not read within `buffer_frames` periods are lost, as on a sensor.
class PacedRgbdSource : public drivers::RgbdSensor {
 public:
  PacedRgbdSource(std::vector<drivers::RgbdFrame> frames, double fps, int buffer_frames, Clock& clock)
      : frames_(std::move(frames)),
        period_(std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(1.0 / fps))),
        buffer_frames_(buffer_frames),
        clock_(clock) {
    info_.backend = "bench";
    info_.id = "paced-rgbd";
    info_.kind = drivers::DeviceKind::kRgbdSensor;
    info_.model = "pre-rendered 640x480 frames at a real 30 fps";
  }
  const drivers::DeviceInfo& info() const override { return info_; }
  std::vector<drivers::RgbdStreamConfig> SupportedConfigs() const override { return {drivers::RgbdStreamConfig{}}; }
  void Start(const drivers::RgbdStreamConfig&) override {
    start_ = SteadyClock::now();
    streaming_ = true;
  }
  void Stop() override { streaming_ = false; }
  bool streaming() const override { return streaming_; }
  drivers::RgbdFrame WaitForFrame(Nanoseconds timeout) override {
    if (!streaming_) throw drivers::DeviceError(drivers::DeviceErrorKind::kTimeout, info_.FullId(), "not streaming");
    // Slots whose frame has been overwritten in the device buffer are lost.
    const auto now_slot = static_cast<std::int64_t>((SteadyClock::now() - start_) / period_);
    if (now_slot - next_slot_ >= buffer_frames_) {
      lost_ += now_slot - buffer_frames_ + 1 - next_slot_;
      next_slot_ = now_slot - buffer_frames_ + 1;
    }
    const auto due = start_ + next_slot_ * period_;
    if (due - SteadyClock::now() > timeout) {
      std::this_thread::sleep_for(timeout);
      throw drivers::DeviceError(drivers::DeviceErrorKind::kTimeout, info_.FullId(), "no frame in time");
    }
    std::this_thread::sleep_until(due);
    drivers::RgbdFrame frame = frames_[static_cast<std::size_t>(next_slot_) % frames_.size()];
    frame.device_id = info_.FullId();
    for (drivers::FrameTiming* t : {&frame.depth_timing, &frame.color_timing}) {
      t->host_utc = clock_.NowUtc();
      t->host_monotonic = clock_.NowMonotonic();
      t->device_timestamp = next_slot_ * period_;
      t->sequence = static_cast<std::uint64_t>(next_slot_);
    }
    ++next_slot_;
    ++delivered_;
    return frame;
  }
  std::int64_t delivered() const { return delivered_; }
  std::int64_t lost() const { return lost_; }

 private:
  std::vector<drivers::RgbdFrame> frames_;
  Nanoseconds period_;
  int buffer_frames_;
  Clock& clock_;
  drivers::DeviceInfo info_;
  SteadyClock::time_point start_;
  bool streaming_ = false;
  std::int64_t next_slot_ = 0;
  std::int64_t delivered_ = 0;
  std::int64_t lost_ = 0;
};

std::vector<drivers::RgbdFrame> PrerenderedFrames(int count) {
  sim::testing::TestRig rig;
  sim::SimRgbdOptions options;
  options.queue_full = sim::SimRgbdOptions::QueueFull::kWait;
  drivers::DeviceInfo info;
  info.backend = "sim";
  info.id = "prerender";
  info.kind = drivers::DeviceKind::kRgbdSensor;
  sim::SimRgbdSensor sensor(info, options, sim::testing::LookingAtWall(640, 480, 58.5), rig.truth, rig.clock);
  sensor.Start(drivers::RgbdStreamConfig{});
  std::vector<drivers::RgbdFrame> frames;
  for (int i = 0; i < count; ++i) frames.push_back(sensor.WaitForFrame(std::chrono::seconds(600)));
  sensor.Stop();
  return frames;
}

// Rendered once per process, shared by every benchmark here.
const std::vector<drivers::RgbdFrame>& Frames() {
  static const std::vector<drivers::RgbdFrame> frames = PrerenderedFrames(4);
  return frames;
}

double StreamSeconds() {
  const char* text = std::getenv("RELUME_RGBD_STREAM_SECONDS");
  return text ? std::max(1.0, std::atof(text)) : 3.0;
}

fs::path BenchmarkDir() {
  const char* dir = std::getenv("RELUME_BENCHMARK_DIR");
  return dir ? fs::path(dir) : fs::temp_directory_path();
}

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double LoadAverage() {
  double load[1] = {0.0};
  return getloadavg(load, 1) == 1 ? load[0] : -1.0;
}

void BM_RgbdRecorder640x480At30Fps(benchmark::State& state) {
  const std::vector<drivers::RgbdFrame>& frames = Frames();
  const double seconds = StreamSeconds();
  for (auto _ : state) {
    const fs::path dir = BenchmarkDir() / "relume_rgbd_recorder_benchmark";
    fs::remove_all(dir);
    SystemClock clock;
    SessionInfo info;
    info.name = "rgbd recorder benchmark";
    info.site = Site::FromDegrees(37.97, 23.72, 150);
    info.clock_name = clock.name();
    info.created_utc = clock.NowUtc();
    SessionWriterOptions storage;
    storage.rgbd_format = state.range(1) == 1 ? RgbdFileFormat::kPng : RgbdFileFormat::kTiffZstd;
    auto writer = SessionWriter::Create(dir, info, storage);
    RecorderOptions options;
    options.rgbd_batch_frames = static_cast<int>(state.range(0));
    options.duration = std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(seconds));
    Recorder recorder(*writer, clock, options);
    auto source = std::make_unique<PacedRgbdSource>(frames, 30.0, 4, clock);
    PacedRgbdSource* paced = source.get();
    recorder.AddRgbdSensor(std::move(source), nullptr, drivers::RgbdStreamConfig{}, 0);
    std::atomic<bool> stop{false};
    const auto t0 = SteadyClock::now();
    const double cpu0 = ProcessCpuSeconds();
    const RecorderSummary summary = recorder.Run(stop);
    const double wall_s = std::chrono::duration<double>(SteadyClock::now() - t0).count();
    const double cpu_s = ProcessCpuSeconds() - cpu0;
    state.SetIterationTime(wall_s);
    state.counters["stream_s"] = seconds;
    state.counters["delivered"] = static_cast<double>(paced->delivered());
    state.counters["stored"] = static_cast<double>(summary.status.rgbd_frames);
    state.counters["dropped_recorder"] = static_cast<double>(summary.status.rgbd_dropped);
    state.counters["dropped_device"] = static_cast<double>(paced->lost());
    // Every thread of the process (reader, writer, OpenCV's encoder pool) per stored frame.
    state.counters["cpu_ms_per_stored_frame"] =
        summary.status.rgbd_frames > 0 ? 1e3 * cpu_s / static_cast<double>(summary.status.rgbd_frames) : 0.0;
    state.counters["load_avg_1min"] = LoadAverage();
    state.counters["disk_MB_per_s"] = static_cast<double>(summary.status.bytes_written) / wall_s / 1e6;
    state.counters["latency_p50_ms"] = summary.rgbd_latency.p50_ms;
    state.counters["latency_p90_ms"] = summary.rgbd_latency.p90_ms;
    state.counters["latency_p99_ms"] = summary.rgbd_latency.p99_ms;
    state.counters["latency_max_ms"] = summary.rgbd_latency.max_ms;
    writer.reset();
    fs::remove_all(dir);
  }
}
BENCHMARK(BM_RgbdRecorder640x480At30Fps)
    ->Args({8, 0})
    ->Args({8, 1})
    ->Args({1, 0})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);

// The parts of one stored frame, for scale: encoding of the depth (16-bit mm) and colour
// (8-bit RGB) images, and a whole SessionWriter::WriteRgbdFrame (encode, write, fsync, rename,
// fsync the folder, commit), one frame after another on one thread.
cv::Mat DepthMm(const drivers::RgbdFrame& f) {
  cv::Mat metres = f.depth_m.clone(), mm;
  cv::patchNaNs(metres, 0.0);
  metres.convertTo(mm, CV_16UC1, 1000.0);
  return mm;
}

// arg 0: 0 = zstd TIFF (tiff_codec.h, level 1, what the session writer uses), 1 = deflate TIFF
// (level 1), 2 = OpenCV's PNG default (zlib level 1, RLE strategy), 3 = PNG at zlib level 0,
// 4 = PNG Huffman-only.
void BM_EncodeRgbd(benchmark::State& state) {
  const std::vector<drivers::RgbdFrame>& frames = Frames();
  std::vector<cv::Mat> depth_mm;
  for (const drivers::RgbdFrame& f : frames) depth_mm.push_back(DepthMm(f));
  const int variant = static_cast<int>(state.range(0));
  std::vector<int> png_params;
  if (variant == 3) png_params = {cv::IMWRITE_PNG_COMPRESSION, 0};
  if (variant == 4) png_params = {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY};
  TiffOptions tiff;
  if (variant == 1) tiff.compression = TiffOptions::Compression::kDeflate;
  auto encode = [&](const cv::Mat& m) {
    if (variant <= 1) return EncodeTiff(m, tiff);
    std::vector<std::uint8_t> bytes;
    cv::imencode(".png", m, bytes, png_params);
    return bytes;
  };
  std::size_t i = 0, depth_bytes = 0, color_bytes = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % frames.size();
    depth_bytes += encode(depth_mm[k]).size();
    color_bytes += encode(frames[k].color.pixels).size();
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["depth_bytes"] = static_cast<double>(depth_bytes) / n;
  state.counters["color_bytes"] = static_cast<double>(color_bytes) / n;
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EncodeRgbd)->DenseRange(0, 4)->Unit(benchmark::kMillisecond);

// arg 0: 0 = zstd TIFF, 1 = PNG.
void BM_WriteRgbdFrame(benchmark::State& state) {
  const std::vector<drivers::RgbdFrame>& frames = Frames();
  const fs::path dir = BenchmarkDir() / "relume_rgbd_write_benchmark";
  fs::remove_all(dir);
  SessionInfo info;
  info.name = "write benchmark";
  info.site = Site::FromDegrees(37.97, 23.72, 150);
  SessionWriterOptions storage;
  storage.rgbd_format = state.range(0) == 1 ? RgbdFileFormat::kPng : RgbdFileFormat::kTiffZstd;
  auto writer = SessionWriter::Create(dir, info, storage);
  std::size_t i = 0;
  for (auto _ : state) writer->WriteRgbdFrame(frames[i++ % frames.size()]);
  state.counters["bytes_per_frame"] =
      static_cast<double>(writer->bytes_written()) / static_cast<double>(state.iterations());
  state.SetItemsProcessed(state.iterations());
  writer.reset();
  fs::remove_all(dir);
}
BENCHMARK(BM_WriteRgbdFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace relume::capture

BENCHMARK_MAIN();
