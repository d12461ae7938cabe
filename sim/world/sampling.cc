#include "sim/world/sampling.h"

#include <cmath>
#include <numbers>

namespace relume::sim {

namespace {
constexpr double kGoldenAngleRad = std::numbers::pi * (3.0 - 2.2360679774997896964);  // pi (3 - sqrt 5)
}  // namespace

std::vector<Eigen::Vector2d> StratifiedDiskPattern(int count) {
  // Point-symmetric, so the pattern's mean is exactly the centre: a Vogel spiral of
  // count / 2 points, each with its mirror image, plus the centre when count is odd.
  std::vector<Eigen::Vector2d> points;
  points.reserve(static_cast<std::size_t>(count));
  if (count % 2 == 1) points.emplace_back(0.0, 0.0);
  const int pairs = count / 2;
  for (int i = 0; i < pairs; ++i) {
    const double r = std::sqrt((i + 0.5) / pairs);
    const double angle = i * kGoldenAngleRad;
    const Eigen::Vector2d p(r * std::cos(angle), r * std::sin(angle));
    points.push_back(p);
    points.push_back(-p);
  }
  return points;
}

Eigen::Vector3d CosineHemisphereFromSquare(double u1, double u2) {
  const double r = std::sqrt(u1);
  const double angle = 2.0 * std::numbers::pi * u2;
  const double x = r * std::cos(angle);
  const double y = r * std::sin(angle);
  return {x, y, std::sqrt(std::max(0.0, 1.0 - u1))};
}

std::vector<Eigen::Vector3d> CosineHemispherePattern(int count) {
  std::vector<Eigen::Vector3d> directions;
  directions.reserve(static_cast<std::size_t>(count));
  constexpr double kInverseGolden = 0.6180339887498949;
  for (int i = 0; i < count; ++i) {
    const double u1 = (i + 0.5) / count;
    const double u2 = std::fmod(i * kInverseGolden, 1.0);
    directions.push_back(CosineHemisphereFromSquare(u1, u2));
  }
  return directions;
}

void OrthonormalBasis(const Eigen::Vector3d& n, Eigen::Vector3d* tangent, Eigen::Vector3d* bitangent) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double b = n.x() * n.y() * a;
  *tangent = {1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x()};
  *bitangent = {b, sign + n.y() * n.y() * a, -n.y()};
}

Pcg32::Pcg32(std::uint64_t seed, std::uint64_t stream) : increment_((stream << 1u) | 1u) {
  NextUint();
  state_ += seed;
  NextUint();
}

std::uint32_t Pcg32::NextUint() {
  const std::uint64_t old = state_;
  state_ = old * 6364136223846793005ULL + increment_;
  const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
  const auto rot = static_cast<std::uint32_t>(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

double Pcg32::NextDouble() {
  return NextUint() * (1.0 / 4294967296.0);
}

Eigen::Vector2d R2Point(std::uint64_t index) {
  constexpr double kA1 = 0.7548776662466927;  // 1 / plastic number
  constexpr double kA2 = 0.5698402909980532;  // 1 / plastic number^2
  const double i = static_cast<double>(index);
  return {std::fmod(0.5 + kA1 * i, 1.0), std::fmod(0.5 + kA2 * i, 1.0)};
}

}  // namespace relume::sim
