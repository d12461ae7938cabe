#include "core/color.h"

#include <Eigen/LU>
#include <cmath>

#include "core/error.h"
#include "core/yaml_file.h"

namespace relume {

namespace {
constexpr double kEpsilon = 216.0 / 24389.0;  // (6/29)^3
constexpr double kKappa = 24389.0 / 27.0;

const Eigen::Matrix3d& Bradford() {
  static const Eigen::Matrix3d m = (Eigen::Matrix3d() << 0.8951, 0.2664, -0.1614,  //
                                    -0.7502, 1.7135, 0.0367,                       //
                                    0.0389, -0.0685, 1.0296)
                                       .finished();
  return m;
}

// sRGB primaries, D65 white (IEC 61966-2-1).
const Eigen::Matrix3d& RgbToXyz() {
  static const Eigen::Matrix3d m = (Eigen::Matrix3d() << 0.4124564, 0.3575761, 0.1804375,  //
                                    0.2126729, 0.7151522, 0.0721750,                       //
                                    0.0193339, 0.1191920, 0.9503041)
                                       .finished();
  return m;
}
}  // namespace

Xyz WhiteD50() {
  return {0.96422, 1.0, 0.82521};
}
Xyz WhiteD65() {
  return {0.95047, 1.0, 1.08883};
}

Xyz XyzFromLab(const Lab& lab, const Xyz& white) {
  const double fy = (lab[0] + 16.0) / 116.0;
  const double fx = fy + lab[1] / 500.0;
  const double fz = fy - lab[2] / 200.0;
  auto inverse = [](double f) { return f * f * f > kEpsilon ? f * f * f : (116.0 * f - 16.0) / kKappa; };
  const double y = lab[0] > kKappa * kEpsilon ? fy * fy * fy : lab[0] / kKappa;
  return {inverse(fx) * white[0], y * white[1], inverse(fz) * white[2]};
}

Lab LabFromXyz(const Xyz& xyz, const Xyz& white) {
  auto f = [](double t) { return t > kEpsilon ? std::cbrt(t) : (kKappa * t + 16.0) / 116.0; };
  const double fx = f(xyz[0] / white[0]);
  const double fy = f(xyz[1] / white[1]);
  const double fz = f(xyz[2] / white[2]);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

Xyz AdaptXyz(const Xyz& xyz, const Xyz& from_white, const Xyz& to_white) {
  const Eigen::Vector3d from_cone = Bradford() * from_white;
  const Eigen::Vector3d to_cone = Bradford() * to_white;
  const Eigen::Matrix3d scale = (to_cone.array() / from_cone.array()).matrix().asDiagonal();
  return Bradford().inverse() * scale * Bradford() * xyz;
}

LinearRgb LinearRgbFromXyzD65(const Xyz& xyz) {
  return RgbToXyz().inverse() * xyz;
}
Xyz XyzD65FromLinearRgb(const LinearRgb& rgb) {
  return RgbToXyz() * rgb;
}

LinearRgb LinearRgbFromLabD50(const Lab& lab) {
  return LinearRgbFromXyzD65(AdaptXyz(XyzFromLab(lab, WhiteD50()), WhiteD50(), WhiteD65()));
}

Lab LabD50FromLinearRgb(const LinearRgb& rgb) {
  return LabFromXyz(AdaptXyz(XyzD65FromLinearRgb(rgb), WhiteD65(), WhiteD50()), WhiteD50());
}

double SrgbEncode(double linear) {
  if (linear <= 0.0031308) return 12.92 * linear;
  return 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

double SrgbDecode(double encoded) {
  if (encoded <= 0.04045) return encoded / 12.92;
  return std::pow((encoded + 0.055) / 1.055, 2.4);
}

ColorCheckerReference LoadColorCheckerReference(const std::string& path) {
  const YamlFile file(path);
  const YAML::Node& root = file.root();
  file.RejectUnknownKeys(root, {"name", "illuminant", "observer", "rows", "columns", "patches"});
  ColorCheckerReference chart;
  chart.name = file.RequireString(root, "name");
  if (file.RequireString(root, "illuminant") != "D50")
    file.Fail(root["illuminant"], "illuminant", "only D50 is supported");
  chart.rows = static_cast<int>(file.RequireDouble(root, "rows"));
  chart.columns = static_cast<int>(file.RequireDouble(root, "columns"));
  const YAML::Node patches = root["patches"];
  if (!patches || !patches.IsSequence()) file.Fail(root, "patches", "expected a list of patches");
  if (static_cast<int>(patches.size()) != chart.rows * chart.columns || chart.rows != 4 || chart.columns != 6) {
    file.Fail(patches, "patches", "expected 24 patches in 4 rows of 6");
  }
  for (const YAML::Node& node : patches) {
    ColorCheckerPatch patch;
    patch.name = file.RequireString(node, "name");
    const YAML::Node lab = node["lab"];
    if (!lab || !lab.IsSequence() || lab.size() != 3) file.Fail(node, "lab", "expected [L*, a*, b*]");
    for (int i = 0; i < 3; ++i) patch.lab_d50[i] = lab[static_cast<std::size_t>(i)].as<double>();
    patch.linear_rgb = LinearRgbFromLabD50(patch.lab_d50);
    chart.patches.push_back(patch);
  }
  return chart;
}

}  // namespace relume
