// Bracket latency through the gphoto2 backend and the real libgphoto2, against simcam.so:
// per frame = Apply (set shutter speed) + Capture (capture, download, delete, decode). ctest
// sets CAMLIBS/IOLIBS/HOME; run by hand with the same variables (docs/backends-gphoto2-openni2.md).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "drivers/gphoto2/gphoto2_backend.h"

namespace relume::drivers::gphoto2 {
namespace {

void BM_SimcamBracketFrame(benchmark::State& state) {
  if (std::getenv("CAMLIBS") == nullptr) {
    state.SkipWithError("CAMLIBS is not set (point it at the build's drivers/gphoto2/camlibs)");
    return;
  }
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("relume-simcam-bench-" + std::to_string(getpid()));
  std::filesystem::create_directories(folder);
  {
    GPhoto2BackendOptions options;
    options.autodetect = false;
    GPhoto2Backend backend(options);
    const std::unique_ptr<GPhoto2Camera> camera = backend.Open({"Relume Simulated DSLR", "disk:" + folder.string()});
    camera->SetConfigValue("imageformat", state.range(0) == 0 ? "JPEG" : "TIFF 16-bit");
    const double bracket_s[] = {1.0 / 1000.0, 1.0 / 250.0, 1.0 / 60.0};
    std::size_t i = 0;
    for (auto _ : state) {
      ExposureSettings settings;
      settings.exposure_time_s = bracket_s[i++ % 3];
      camera->Apply(settings);
      benchmark::DoNotOptimize(camera->Capture());
    }
  }
  std::filesystem::remove_all(folder);
  state.SetLabel(state.range(0) == 0 ? "jpeg 240x160" : "tiff16 240x160");
}
BENCHMARK(BM_SimcamBracketFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace relume::drivers::gphoto2

BENCHMARK_MAIN();
