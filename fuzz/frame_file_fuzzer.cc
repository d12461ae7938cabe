// Frame files as a session reader decodes them (capture/session.h DecodeFrameImage: PNG, TIFF,
// JPEG through OpenCV, camera raw such as DNG through LibRaw). The first byte chooses the format
// the row claims; the rest is the file.
//
// RELUME_FUZZ_SKIP_RAW=1 leaves the raw formats out: Debian 12's LibRaw 0.20.2 crashes (SIGSEGV
// in LibRaw::parse_tiff_ifd) on some damaged TIFF-based raw files, which relume cannot catch in
// process; the CTest run sets it so that CI fails only on relume's own bugs, and scripts/fuzz.sh
// fuzzes every format (docs/ci.md, "Fuzzing").
#include <cstdlib>
#include <cstring>

#include "capture/session.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static const char* kFormats[] = {"png", "tiff", "jpeg", "dng", "nef", "cr2"};
  static const bool skip_raw =
      std::getenv("RELUME_FUZZ_SKIP_RAW") != nullptr && std::strcmp(std::getenv("RELUME_FUZZ_SKIP_RAW"), "1") == 0;
  const std::size_t formats = skip_raw ? 3 : std::size(kFormats);
  relume::capture::FrameRecord frame;
  frame.file_format = kFormats[data[0] % formats];
  frame.bits_per_sample = data[0] & 0x80 ? 16 : 8;
  frame.white_level = (1 << frame.bits_per_sample) - 1;
  relume::fuzz::ExpectRelumeErrorsOnly([&] {
    relume::capture::DecodeFrameImage({data + 1, size - 1}, frame, "fuzz." + frame.file_format);
  });
  return 0;
}
