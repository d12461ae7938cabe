// A session's database (`relume session verify|info|recover`, every reader of a session):
// capture/session.h SessionReader and capture/session_check.h. The input is session.sqlite.
#include "capture/session.h"
#include "capture/session_check.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = relume::fuzz::WriteScratch("session/session.sqlite", {data, size});
  const auto dir = path.parent_path();
  for (const char* suffix : {"-wal", "-shm"}) std::filesystem::remove(dir / (std::string("session.sqlite") + suffix));
  relume::fuzz::ExpectRelumeErrorsOnly([&] {
    const relume::capture::SessionReader reader(dir);
    reader.Devices();
    reader.Brackets();
    reader.Events();
    reader.Calibrations();
    for (const auto& frame : reader.Frames()) {
      relume::fuzz::ExpectRelumeErrorsOnly([&] { reader.LoadImage(frame); });
    }
  });
  relume::fuzz::ExpectRelumeErrorsOnly([&] { relume::capture::VerifySession(dir); });
  relume::fuzz::ExpectRelumeErrorsOnly([&] { relume::capture::DescribeSession(dir); });
  return 0;
}
