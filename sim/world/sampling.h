// Deterministic sample patterns for the simulated world's light integrals.
//
// Conventions: every pattern is a pure function of its size (and, for the scrambled
// sequence, of an explicit seed), so a render is bit-for-bit repeatable. Directions are unit
// vectors; "local" hemisphere directions have z along the surface normal.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace relume::sim {

// `count` points on the unit disk, stratified by area and point-symmetric (mean exactly 0):
// a Vogel (golden-angle) spiral of count / 2 points, r_i = sqrt((i + 0.5) / (count / 2)),
// each with its mirror image, plus the centre when count is odd. Used for the sun's disk.
std::vector<Eigen::Vector2d> StratifiedDiskPattern(int count);

// `count` cosine-weighted directions on the local hemisphere (z >= 0): a Fibonacci lattice
// on the unit disk lifted to the hemisphere (Malley's method). The mean of f over these
// directions estimates (1 / pi) * integral of f(w) cos(theta) dw.
std::vector<Eigen::Vector3d> CosineHemispherePattern(int count);

// An orthonormal basis (tangent, bitangent) completing the unit vector n (Duff et al. 2017).
void OrthonormalBasis(const Eigen::Vector3d& n, Eigen::Vector3d* tangent, Eigen::Vector3d* bitangent);

// Maps a point of [0,1)^2 to a cosine-weighted local hemisphere direction.
Eigen::Vector3d CosineHemisphereFromSquare(double u1, double u2);

// A small, fast, deterministic generator (PCG32) for the indirect-light estimate.
class Pcg32 {
 public:
  Pcg32(std::uint64_t seed, std::uint64_t stream);
  std::uint32_t NextUint();
  double NextDouble();  // [0, 1)

 private:
  std::uint64_t state_ = 0;
  std::uint64_t increment_ = 0;
};

// 2D R2 low-discrepancy sequence point i (Roberts 2018), in [0,1)^2.
Eigen::Vector2d R2Point(std::uint64_t index);

}  // namespace relume::sim
