// Frames per second from Aravis's in-process fake and from its GigE fake on 127.0.0.1, and
// the time per frame of an exposure bracket (apply + capture).
#include <benchmark/benchmark.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <thread>

#include "drivers/aravis/aravis_backend.h"
#include "drivers/aravis/fake_radiance_painter.h"

namespace relume::drivers::aravis {
namespace {

std::unique_ptr<AravisCamera> OpenFake(int width, int height) {
  AravisBackendOptions options;
  options.gige_discovery = false;
  options.usb3 = false;
  options.fake = true;
  options.camera.raw_gain_db_per_step = 1.0;
  DeviceInfo wanted;
  wanted.id = "Fake_1";
  auto camera = AravisBackend(options).OpenCamera(wanted);
  camera->SetRegion(0, 0, width, height);
  camera->SetPixelFormat("Mono16");
  camera->SetFrameRate(1000.0);
  return camera;
}

void BM_FakeStreaming(benchmark::State& state) {
  const int size = static_cast<int>(state.range(0));
  auto camera = OpenFake(size, size);
  testing::FakeRadiancePainter painter(std::make_shared<testing::RadianceRampTruth>(10.0, 0.1, 0.1), {});
  painter.Install(camera->native_device());
  camera->StartStreaming();
  for (auto _ : state) benchmark::DoNotOptimize(camera->WaitForFrame(std::chrono::seconds(2)));
  camera->StopStreaming();
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["lost_ids"] = static_cast<double>(camera->statistics().lost_ids);
}
BENCHMARK(BM_FakeStreaming)->Arg(64)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_FakeBracketPerFrame(benchmark::State& state) {
  auto camera = OpenFake(64, 48);
  testing::FakeRadiancePainter painter(std::make_shared<testing::RadianceRampTruth>(10.0, 0.1, 0.1), {});
  painter.Install(camera->native_device());
  const std::vector<double> times = {0.0001, 0.0002, 0.0004, 0.0008, 0.0016};
  for (auto _ : state) benchmark::DoNotOptimize(camera->CaptureBracket(times));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(times.size()));
}
BENCHMARK(BM_FakeBracketPerFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GigELoopbackStreaming(benchmark::State& state) {
  std::string path = RELUME_ARV_FAKE_GV_CAMERA;
  if (path.empty() || !std::filesystem::exists(path)) {
    state.SkipWithError("arv-fake-gv-camera-0.8 is not installed");
    return;
  }
  const std::string serial = "RELUMEBM" + std::to_string(getpid());
  const pid_t pid = fork();
  if (pid == 0) {
    execl(path.c_str(), path.c_str(), "-i", "127.0.0.1", "-s", serial.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  AravisBackendOptions options;
  options.gige_discovery = false;  // unicast to 127.0.0.1 only
  options.usb3 = false;
  options.gige_addresses = {"127.0.0.1"};
  std::optional<DeviceInfo> info;
  for (int i = 0; i < 20 && !info; ++i) {
    for (const DeviceInfo& d : ListAravisDevices(options))
      if (d.serial == serial) info = d;
    if (!info) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (!info) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    state.SkipWithError("the GigE fake on 127.0.0.1 did not answer");
    return;
  }
  {
    auto camera = AravisBackend(options).OpenCamera(*info);
    const int size = static_cast<int>(state.range(0));
    camera->SetRegion(0, 0, size, size);
    camera->SetPixelFormat("Mono8");
    camera->SetFrameRate(200.0);
    camera->StartStreaming();
    for (auto _ : state) benchmark::DoNotOptimize(camera->WaitForFrame(std::chrono::seconds(2)));
    camera->StopStreaming();
    state.counters["frames_per_s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["lost_ids"] = static_cast<double>(camera->statistics().lost_ids);
    state.counters["incomplete"] = static_cast<double>(camera->statistics().failed);
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}
BENCHMARK(BM_GigELoopbackStreaming)->Arg(64)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(100);

}  // namespace
}  // namespace relume::drivers::aravis

BENCHMARK_MAIN();
