// Writing ground truth to disk: float EXR files (the values themselves) and 8-bit PNG
// previews (for eyes only). Files are RGB in relume and BGR in OpenCV: channels are swapped
// here, at the file edge.
//
// Files: radiance, depth (metres), normals, albedo, sun_visibility, irradiance (W m^-2),
// each as NAME.exr and NAME.png. EXR keeps NaN (no surface). Previews: radiance scaled so
// its 99th percentile is 1, then sRGB-encoded; depth scaled by the largest depth; normals
// mapped (n + 1) / 2; albedo sRGB-encoded; sun_visibility as is; irradiance scaled by its
// 99th percentile. NaN is black in previews.
#pragma once

#include <string>

#include "sim/truth.h"

namespace relume::sim {

// Creates `folder` when needed. Throws IoError naming the file that could not be written.
void WriteGroundTruth(const GroundTruth& truth, const std::string& folder);

}  // namespace relume::sim
