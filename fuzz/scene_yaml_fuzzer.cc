// Simulated-world scene files (a rig's `scene:`, `relume sim render`): sim/world/scene_yaml.h.
#include "fuzz/fuzz_util.h"
#include "sim/world/scene_yaml.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = relume::fuzz::WriteScratch("scene.yaml", {data, size});
  relume::fuzz::ExpectRelumeErrorsOnly([&] { relume::sim::LoadScene(path.string()); });
  return 0;
}
