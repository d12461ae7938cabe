// Rig files (`relume capture --rig`, `relume devices --rig`): rig/rig_config.h.
#include "fuzz/fuzz_util.h"
#include "rig/rig_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = relume::fuzz::WriteScratch("rig.yaml", {data, size});
  relume::fuzz::ExpectRelumeErrorsOnly([&] { relume::rig::LoadRigConfig(path.string()); });
  return 0;
}
