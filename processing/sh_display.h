// Pictures of an SH lighting estimate (Ogura et al. show theirs as a cube map).
//
// Conventions:
//  - Images are CV_32FC3, linear RGB, of the radiance sum_k L_k Y_k(w) or of the irradiance
//    E(w) (processing/sh.h), as chosen; values may be negative where a band-limited light
//    rings. Encoding for display (tone mapping, sRGB) is the caller's business.
//  - Lat-long: the convention of processing/sh.h, with sh_from_map rotating map directions
//    into the SH frame.
//  - Cube cross, 4 faces wide and 3 high, directions in the SH frame (the camera frame:
//    x right, y down, z forward), each face seen from inside the cube:
//                 [-Y up]
//        [-X left][+Z front][+X right][-Z back]
//                 [+Y down]
//    Within a face, s runs left to right and t top to bottom over [-1, 1]: front (s, t, 1),
//    right (1, t, -s), back (-s, t, -1), left (-1, t, s), up (s, -1, t), down (s, 1, -t).
//    Cells outside the cross are 0.
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "processing/sh.h"

namespace relume::processing {

enum class ShDisplayQuantity { kRadiance, kIrradiance };

cv::Mat ShToLatLong(const ShRgb& light, int width, int height, ShDisplayQuantity quantity,
                    const Eigen::Matrix3d& sh_from_map = Eigen::Matrix3d::Identity());
cv::Mat ShToCubeCross(const ShRgb& light, int face_size, ShDisplayQuantity quantity);

// The SH-frame direction through cube-cross pixel (x, y), or false outside the cross.
bool CubeCrossDirection(int x, int y, int face_size, Eigen::Vector3d* direction);

}  // namespace relume::processing
