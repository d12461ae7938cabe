// Loads a scene description from YAML (config/scenes/*.yaml; the format is documented in
// docs/sim-world.md). Errors are ConfigError "FILE:LINE: KEY: what" (core/yaml_file.h);
// files a scene refers to (meshes, the ColorChecker reference) are resolved relative to the
// scene file's folder.
//
// Coordinates: ENU metres at the site unless the file has `utm_zone`; then every position
// in the file (object and mesh vertices, lamp positions, camera poses, motion centres and
// waypoints) is UTM easting, northing and ellipsoidal height in that zone, and every
// direction is in the grid frame. They are converted exactly to the site's ENU frame
// (through geodetic coordinates), which turns grid north onto true north (meridian
// convergence) and undoes the grid's scale factor.
#pragma once

#include <string>

#include "sim/world/scene.h"

namespace relume::sim {

Scene LoadScene(const std::string& path);

}  // namespace relume::sim
