// Real spherical harmonics to order 2, irradiance from SH lighting, and environment maps.
//
// Conventions (stated once, here; every processing/sh_* file follows them):
//  - Index: coefficient k = l * (l + 1) + m for band l = 0..2 and m = -l..l, so k = 0 is
//    (0,0); 1..3 are (1,-1), (1,0), (1,1); 4..8 are (2,-2) .. (2,2). Order 1 uses k < 4.
//  - Basis: real, orthonormal over the unit sphere (integral of Y_k Y_j over 4 pi sr is
//    delta_kj), no Condon-Shortley phase, for a unit direction d = (x, y, z):
//      Y00 = 0.282095
//      Y1-1 = 0.488603 y     Y10 = 0.488603 z      Y11 = 0.488603 x
//      Y2-2 = 1.092548 x y   Y2-1 = 1.092548 y z   Y20 = 0.315392 (3 z^2 - 1)
//      Y21 = 1.092548 x z    Y22 = 0.546274 (x^2 - y^2)
//  - Lighting: ShRgb holds the radiance coefficients L_k = integral of L(w) Y_k(w) dw for R,
//    G, B (column c = channel). Directions w point from the surface toward the light and are
//    expressed in the frame the coefficients live in: the camera frame (x right, y down,
//    z forward; core/pinhole.h) for everything processing estimates.
//  - Irradiance (Ramamoorthi & Hanrahan 2001): E(n) = sum_k A_l(k) L_k Y_k(n) with the
//    clamped-cosine band factors A0 = pi, A1 = 2 pi / 3, A2 = pi / 4. Lambertian radiance is
//    I = albedo * E(n) / pi (the same convention as sim/truth.h).
//  - Lat-long environment maps (RadianceImage, W x H, RGB): pixel (u, v) covers polar angle
//    theta in [pi v / H, pi (v + 1) / H] from the map's +z ("up", top row) and azimuth phi in
//    [2 pi u / W, 2 pi (u + 1) / W] from +x toward +y; its centre direction in the map frame
//    is (sin theta cos phi, sin theta sin phi, cos theta). `sh_from_map` rotates map
//    directions into the SH frame. A pixel's solid angle is (2 pi / W)(cos theta0 - cos theta1).
#pragma once

#include <Eigen/Core>
#include <numbers>

#include "core/image.h"

namespace relume::processing {

inline constexpr int kShCount = 9;  // coefficients to order 2
constexpr int ShIndex(int l, int m) {
  return l * (l + 1) + m;
}
constexpr int ShCountForOrder(int order) {
  return (order + 1) * (order + 1);
}
// A_l for the band of coefficient k.
constexpr double ShBandFactor(int l) {
  return l == 0 ? std::numbers::pi : l == 1 ? 2.0 * std::numbers::pi / 3.0 : std::numbers::pi / 4.0;
}

using ShVector = Eigen::Matrix<double, kShCount, 1>;
using ShRgb = Eigen::Matrix<double, kShCount, 3>;  // rows: k, columns: R, G, B

// Y_k(d) for a unit direction d (not normalised here: pass a unit vector).
ShVector ShBasis(const Eigen::Vector3d& d);
// Y_k(d) * A_l(k): the irradiance kernel, so that E(n) = IrradianceBasis(n).transpose() * L.
ShVector ShIrradianceBasis(const Eigen::Vector3d& n);

// Irradiance E(n) per channel for a unit normal n.
Eigen::Vector3d ShIrradiance(const ShRgb& light, const Eigen::Vector3d& n);
// Radiance L(w) = sum_k L_k Y_k(w) of the band-limited light itself.
Eigen::Vector3d ShRadiance(const ShRgb& light, const Eigen::Vector3d& w);
// The mean irradiance over all normals, A0 L00 Y00 per channel: the scale that "near zero"
// irradiance is judged against.
Eigen::Vector3d ShMeanIrradiance(const ShRgb& light);
// Keeps coefficients up to `order` (0, 1 or 2) and zeroes the rest.
ShRgb TruncateSh(const ShRgb& light, int order);

// Lat-long map helpers (see the conventions above).
Eigen::Vector3d LatLongDirection(double u, double v, int width, int height);  // continuous (u, v)
double LatLongPixelSolidAngle(int row, int width, int height);

// Projects a lat-long environment map (RGB radiance) onto SH to order 2, in the SH frame.
// Throws InvalidArgumentError for an empty, non-RGB or non-finite map.
ShRgb ProjectEnvironmentMap(const RadianceImage& latlong, const Eigen::Matrix3d& sh_from_map);
// Irradiance at unit normal n (SH frame) by direct summation over every map pixel: the
// reference the 9-coefficient approximation is checked against.
Eigen::Vector3d IntegrateIrradiance(const RadianceImage& latlong, const Eigen::Matrix3d& sh_from_map,
                                    const Eigen::Vector3d& n);

}  // namespace relume::processing
