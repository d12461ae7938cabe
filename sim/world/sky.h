// The sky of the simulated world: radiance as a function of direction, and its projection on
// real spherical harmonics of order 2.
//
// Conventions:
//  - Directions are unit vectors in the scene's ENU frame (z up), pointing from the scene
//    toward the sky.
//  - Radiance is linear RGB, W m^-2 sr^-1 per channel. The sky covers the upper hemisphere
//    only: below the horizon (z < 0) its radiance is 0 (the ground, when there is one, is
//    scene geometry and lights only through indirect bounces).
//  - kUniform: L(w) = zenith_radiance for z >= 0.
//    kGradient: L(w) = horizon + (zenith - horizon) * z for z >= 0 — smooth from the horizon
//    (elevation 0) to the zenith; an unoccluded horizontal plane receives
//    E = pi * horizon + (2 pi / 3) * (zenith - horizon).
//  - SH: real, orthonormal spherical harmonics on the unit sphere, index l * (l + 1) + m,
//    Y00 = 0.282095, Y1-1 = 0.488603 y, Y10 = 0.488603 z, Y11 = 0.488603 x,
//    Y2-2 = 1.092548 xy, Y2-1 = 1.092548 yz, Y20 = 0.315392 (3 z^2 - 1),
//    Y21 = 1.092548 xz, Y22 = 0.546274 (x^2 - y^2); coefficient c_lm = integral L(w) Y_lm(w) dw.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>

namespace relume::sim {

using ShCoefficients = std::array<Eigen::Vector3d, 9>;  // RGB per coefficient, index l(l+1)+m

// The nine order-2 real SH basis functions at a unit direction.
std::array<double, 9> ShBasis(const Eigen::Vector3d& direction);

struct Sky {
  enum class Type { kBlack, kUniform, kGradient };
  Type type = Type::kBlack;
  Eigen::Vector3d zenith_radiance = Eigen::Vector3d::Zero();   // W m^-2 sr^-1
  Eigen::Vector3d horizon_radiance = Eigen::Vector3d::Zero();  // kGradient only

  static Sky Black() { return {}; }
  static Sky Uniform(const Eigen::Vector3d& radiance) { return {Type::kUniform, radiance, radiance}; }
  static Sky Gradient(const Eigen::Vector3d& zenith, const Eigen::Vector3d& horizon) {
    return {Type::kGradient, zenith, horizon};
  }

  bool IsBlack() const;
  bool IsValid(std::string* why) const;
  Eigen::Vector3d Radiance(const Eigen::Vector3d& direction_in_enu) const;
  // Irradiance on an unoccluded horizontal, upward-facing plane (analytic).
  Eigen::Vector3d HorizontalIrradiance() const;
  // Order-2 SH projection by midpoint quadrature on a (theta, phi) grid of
  // `theta_steps` x 2 theta_steps cells; the default resolves the coefficients to ~1e-5
  // relative (the horizon cut is the only non-smooth part).
  ShCoefficients ProjectSh(int theta_steps = 512) const;
};

const char* ToString(Sky::Type type);

// Irradiance on a surface with unit normal n from a lighting given by order-2 SH coefficients
// (Ramamoorthi & Hanrahan 2001: A0 = pi, A1 = 2 pi / 3, A2 = pi / 4). Exact when the
// lighting is band-limited to order 2.
Eigen::Vector3d IrradianceFromSh(const ShCoefficients& sh, const Eigen::Vector3d& normal);

}  // namespace relume::sim
