// JSON a user hands relume: calibration profiles (`--profile`, calibration rows of a session:
// calibration/calibration_profile.h) and SH lights (`--target-light L.json`:
// pipeline/sh_pipeline.h). The first byte chooses the reader.
#include <nlohmann/json.hpp>

#include "calibration/calibration_profile.h"
#include "fuzz/fuzz_util.h"
#include "pipeline/sh_pipeline.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  relume::fuzz::ExpectRelumeErrorsOnly([&] {
    if ((data[0] & 1) == 0) {
      relume::calibration::ProfileFromJson(text, "fuzz.json");
      return;
    }
    // As the pipeline reads a light file: text that is not JSON is an InvalidArgumentError there.
    const nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (json.is_discarded()) return;
    relume::pipeline::ShLightFromJson(json, "fuzz.json");
  });
  return 0;
}
