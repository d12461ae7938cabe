// Colour spaces relume converts between, and the ColorChecker reference chart.
//
// Conventions:
//  - "Linear RGB" is linear sRGB / Rec.709 primaries with a D65 white: the space radiance
//    images are in after calibration, and the space the simulator renders albedo in.
//  - XYZ is scaled so that the reference white has Y = 1.
//  - L*a*b* values name their white (D50 for the ColorChecker reference data). D50 <-> D65
//    uses the Bradford chromatic adaptation.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace relume {

using Lab = Eigen::Vector3d;  // L*, a*, b*
using Xyz = Eigen::Vector3d;
using LinearRgb = Eigen::Vector3d;

// Reference whites (Y = 1).
Xyz WhiteD50();
Xyz WhiteD65();

Xyz XyzFromLab(const Lab& lab, const Xyz& white);
Lab LabFromXyz(const Xyz& xyz, const Xyz& white);
// Bradford adaptation of XYZ from one white to another.
Xyz AdaptXyz(const Xyz& xyz, const Xyz& from_white, const Xyz& to_white);
// XYZ (D65) <-> linear sRGB.
LinearRgb LinearRgbFromXyzD65(const Xyz& xyz);
Xyz XyzD65FromLinearRgb(const LinearRgb& rgb);
// Convenience: reference L*a*b* (D50) -> linear sRGB (D65) reflectance, and back.
LinearRgb LinearRgbFromLabD50(const Lab& lab);
Lab LabD50FromLinearRgb(const LinearRgb& rgb);
// sRGB transfer function for 8-bit previews (per channel, input linear in [0, 1]).
double SrgbEncode(double linear);
double SrgbDecode(double encoded);

struct ColorCheckerPatch {
  std::string name;
  Lab lab_d50;
  LinearRgb linear_rgb;  // reflectance in linear sRGB (D65), from lab_d50
};

struct ColorCheckerReference {
  std::string name;
  int rows = 4;
  int columns = 6;
  std::vector<ColorCheckerPatch> patches;  // rows * columns, in reading order
  // Indices of the six neutral patches (white .. black), brightest first.
  std::vector<int> NeutralIndices() const { return {18, 19, 20, 21, 22, 23}; }
};

// Loads config/colorchecker/*.yaml. Throws ConfigError/IoError naming the file and key.
ColorCheckerReference LoadColorCheckerReference(const std::string& path);

}  // namespace relume
