// GenICam pixel formats (PFNC codes, as Aravis reports them) that relume reads, and their
// conversion into core CameraImage (core/image.h: channels R, G, B; sensor-linear counts).
//
// Supported: Mono8, Mono10, Mono12, Mono14, Mono16 (unpacked, little-endian 16-bit words),
// BayerRG/BG/GR/GB 8, 10, 12, 16 (unpacked), RGB8 (RGB8Packed) and BGR8 (reordered to RGB).
// Packed 10/12-bit and YUV formats are not read: choose an unpacked format on the camera.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "core/image.h"

namespace relume::drivers::aravis {

struct PixelFormatInfo {
  std::uint32_t pfnc = 0;
  const char* name = "";  // GenICam name, e.g. "Mono16"
  ColorLayout layout = ColorLayout::kMono;
  int bits_per_sample = 8;  // significant bits
  int bytes_per_pixel = 1;  // storage of one pixel (all channels)
};

// The format for a PFNC code or a GenICam name; nullopt when relume does not read it.
std::optional<PixelFormatInfo> FindPixelFormat(std::uint32_t pfnc);
std::optional<PixelFormatInfo> FindPixelFormat(const std::string& name);

// Copies one image out of a buffer: `row_padding_bytes` follow each row. Throws
// DeviceError(kCorruptFrame) when `size` is too small and kUnsupportedSetting for a format
// relume does not read. `device_id` names the camera in messages.
CameraImage ImageFromPixels(const void* data, std::size_t size, std::uint32_t pfnc, int width, int height,
                            int row_padding_bytes, const std::string& device_id);

}  // namespace relume::drivers::aravis
