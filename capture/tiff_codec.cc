#include "capture/tiff_codec.h"

#include <tiffio.h>

#include <algorithm>
#include <cstring>

#include "core/error.h"

namespace relume::capture {
namespace {

// libtiff writes through these callbacks into a growing buffer (it seeks back to patch the
// header and strip offsets, so this is a seekable memory file, not a stream).
struct MemoryFile {
  std::vector<std::uint8_t> bytes;
  std::size_t position = 0;
};

tmsize_t Read(thandle_t handle, void* data, tmsize_t size) {
  auto* file = static_cast<MemoryFile*>(handle);
  const std::size_t n =
      std::min(static_cast<std::size_t>(size), file->bytes.size() - std::min(file->position, file->bytes.size()));
  if (n > 0) std::memcpy(data, file->bytes.data() + file->position, n);
  file->position += n;
  return static_cast<tmsize_t>(n);
}

tmsize_t Write(thandle_t handle, void* data, tmsize_t size) {
  auto* file = static_cast<MemoryFile*>(handle);
  const auto n = static_cast<std::size_t>(size);
  if (file->position + n > file->bytes.size()) file->bytes.resize(file->position + n);
  std::memcpy(file->bytes.data() + file->position, data, n);
  file->position += n;
  return size;
}

toff_t Seek(thandle_t handle, toff_t offset, int whence) {
  auto* file = static_cast<MemoryFile*>(handle);
  const std::size_t base = whence == SEEK_SET ? 0 : whence == SEEK_CUR ? file->position : file->bytes.size();
  file->position = base + static_cast<std::size_t>(offset);
  return static_cast<toff_t>(file->position);
}

int Close(thandle_t) {
  return 0;
}
toff_t Size(thandle_t handle) {
  return static_cast<toff_t>(static_cast<MemoryFile*>(handle)->bytes.size());
}
int Map(thandle_t, void**, toff_t*) {
  return 0;
}
void Unmap(thandle_t, void*, toff_t) {}

}  // namespace

bool TiffOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* text) {
    if (why) *why = text;
    return false;
  };
  if (compression == Compression::kZstd && !(level >= 1 && level <= 19)) return fail("zstd level must be in [1, 19]");
  if (compression == Compression::kDeflate && !(level >= 1 && level <= 9)) {
    return fail("deflate level must be in [1, 9]");
  }
  if (rows_per_strip < 1) return fail("rows_per_strip must be at least 1");
  return true;
}

std::vector<std::uint8_t> EncodeTiff(const cv::Mat& pixels, const TiffOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgumentError("TIFF options: " + why);
  const int depth = pixels.depth(), channels = pixels.channels();
  if ((depth != CV_8U && depth != CV_16U && depth != CV_32F) || (channels != 1 && channels != 3) || pixels.empty()) {
    throw InvalidArgumentError(
        "TIFF encoder: expected a non-empty 8- or 16-bit unsigned or 32-bit float image with 1 or 3 channels");
  }
  MemoryFile file;
  TIFF* tiff = TIFFClientOpen("relume frame", "wl", &file, Read, Write, Seek, Close, Size, Map, Unmap);
  if (tiff == nullptr) throw IoError("TIFF encoder", "libtiff could not start a file");
  const int bits = depth == CV_8U ? 8 : depth == CV_16U ? 16 : 32;
  const bool is_float = depth == CV_32F;
  // Floats are differenced byte plane by byte plane (TIFF Technical Note 3), integers sample by sample.
  const auto predictor = static_cast<std::uint16_t>(is_float ? PREDICTOR_FLOATINGPOINT : PREDICTOR_HORIZONTAL);
  TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(pixels.cols));
  TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(pixels.rows));
  TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(channels));
  TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(bits));
  TIFFSetField(tiff, TIFFTAG_SAMPLEFORMAT,
               static_cast<std::uint16_t>(is_float ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT));
  TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC,
               static_cast<std::uint16_t>(channels == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK));
  TIFFSetField(tiff, TIFFTAG_PLANARCONFIG, static_cast<std::uint16_t>(PLANARCONFIG_CONTIG));
  TIFFSetField(tiff, TIFFTAG_ROWSPERSTRIP, static_cast<std::uint32_t>(options.rows_per_strip));
  switch (options.compression) {
    case TiffOptions::Compression::kZstd:
      TIFFSetField(tiff, TIFFTAG_COMPRESSION, static_cast<std::uint16_t>(COMPRESSION_ZSTD));
      TIFFSetField(tiff, TIFFTAG_ZSTD_LEVEL, options.level);
      TIFFSetField(tiff, TIFFTAG_PREDICTOR, predictor);
      break;
    case TiffOptions::Compression::kDeflate:
      TIFFSetField(tiff, TIFFTAG_COMPRESSION, static_cast<std::uint16_t>(COMPRESSION_ADOBE_DEFLATE));
      TIFFSetField(tiff, TIFFTAG_ZIPQUALITY, options.level);
      TIFFSetField(tiff, TIFFTAG_PREDICTOR, predictor);
      break;
    case TiffOptions::Compression::kNone:
      TIFFSetField(tiff, TIFFTAG_COMPRESSION, static_cast<std::uint16_t>(COMPRESSION_NONE));
      break;
  }
  // The predictor differences the row in place, so each row goes through a scratch copy.
  const std::size_t row_bytes = static_cast<std::size_t>(pixels.cols) * pixels.elemSize();
  std::vector<std::uint8_t> row(row_bytes);
  bool ok = true;
  for (int y = 0; y < pixels.rows && ok; ++y) {
    std::memcpy(row.data(), pixels.ptr(y), row_bytes);
    ok = TIFFWriteScanline(tiff, row.data(), static_cast<std::uint32_t>(y), 0) == 1;
  }
  ok = TIFFFlush(tiff) == 1 && ok;  // writes the directory
  TIFFClose(tiff);
  if (!ok) throw IoError("TIFF encoder", "libtiff could not encode the frame");
  return std::move(file.bytes);
}

}  // namespace relume::capture
