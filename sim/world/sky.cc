#include "sim/world/sky.h"

#include <cmath>
#include <numbers>

namespace relume::sim {

std::array<double, 9> ShBasis(const Eigen::Vector3d& d) {
  const double x = d.x(), y = d.y(), z = d.z();
  return {0.28209479177387814,
          0.4886025119029199 * y,
          0.4886025119029199 * z,
          0.4886025119029199 * x,
          1.0925484305920792 * x * y,
          1.0925484305920792 * y * z,
          0.31539156525252005 * (3.0 * z * z - 1.0),
          1.0925484305920792 * x * z,
          0.5462742152960396 * (x * x - y * y)};
}

const char* ToString(Sky::Type type) {
  switch (type) {
    case Sky::Type::kBlack: return "black";
    case Sky::Type::kUniform: return "uniform";
    case Sky::Type::kGradient: return "gradient";
  }
  return "?";
}

bool Sky::IsBlack() const {
  return type == Type::kBlack || (zenith_radiance.isZero(0.0) && horizon_radiance.isZero(0.0));
}

bool Sky::IsValid(std::string* why) const {
  const bool ok = zenith_radiance.allFinite() && horizon_radiance.allFinite() && zenith_radiance.minCoeff() >= 0.0 &&
                  horizon_radiance.minCoeff() >= 0.0;
  if (!ok && why) *why = "sky radiance must be finite and non-negative";
  return ok;
}

Eigen::Vector3d Sky::Radiance(const Eigen::Vector3d& d) const {
  if (d.z() < 0.0) return Eigen::Vector3d::Zero();
  switch (type) {
    case Type::kBlack: return Eigen::Vector3d::Zero();
    case Type::kUniform: return zenith_radiance;
    case Type::kGradient: return horizon_radiance + (zenith_radiance - horizon_radiance) * d.z();
  }
  return Eigen::Vector3d::Zero();
}

Eigen::Vector3d Sky::HorizontalIrradiance() const {
  switch (type) {
    case Type::kBlack: return Eigen::Vector3d::Zero();
    case Type::kUniform: return std::numbers::pi * zenith_radiance;
    case Type::kGradient:
      return std::numbers::pi * horizon_radiance +
             (2.0 * std::numbers::pi / 3.0) * (zenith_radiance - horizon_radiance);
  }
  return Eigen::Vector3d::Zero();
}

ShCoefficients Sky::ProjectSh(int theta_steps) const {
  ShCoefficients sh;
  for (auto& c : sh) c.setZero();
  if (IsBlack()) return sh;
  // Only the upper hemisphere carries light: integrate theta over [0, pi/2] with the cut on a
  // cell boundary, so the quadrature sees a smooth integrand.
  const int phi_steps = 2 * theta_steps;
  const double d_theta = 0.5 * std::numbers::pi / theta_steps;
  const double d_phi = 2.0 * std::numbers::pi / phi_steps;
  for (int i = 0; i < theta_steps; ++i) {
    const double theta = (i + 0.5) * d_theta;
    const double weight = std::sin(theta) * d_theta * d_phi;
    for (int j = 0; j < phi_steps; ++j) {
      const double phi = (j + 0.5) * d_phi;
      const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      const Eigen::Vector3d radiance = Radiance(d) * weight;
      const auto basis = ShBasis(d);
      for (int k = 0; k < 9; ++k) sh[static_cast<std::size_t>(k)] += radiance * basis[static_cast<std::size_t>(k)];
    }
  }
  return sh;
}

Eigen::Vector3d IrradianceFromSh(const ShCoefficients& sh, const Eigen::Vector3d& normal) {
  constexpr double kBand[9] = {std::numbers::pi,           2.0 * std::numbers::pi / 3, 2.0 * std::numbers::pi / 3,
                               2.0 * std::numbers::pi / 3, std::numbers::pi / 4,       std::numbers::pi / 4,
                               std::numbers::pi / 4,       std::numbers::pi / 4,       std::numbers::pi / 4};
  const auto basis = ShBasis(normal);
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < 9; ++k) e += kBand[k] * basis[k] * sh[k];
  return e;
}

}  // namespace relume::sim
