// `relume sun --csv FILE`: apps/relume/sun_command.h.
#include <sstream>

#include "apps/relume/sun_command.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::ostringstream out;
  relume::app::SunQuery query;
  query.latitude_deg = 37.97;
  query.longitude_deg = 23.72;
  relume::fuzz::ExpectRelumeErrorsOnly([&] { relume::app::RunSunCsv(query, in, "fuzz.csv", out); });
  return 0;
}
