// `relume sim render SCENE --camera NAME [--time ISO] --out DIR [--width W --height H]`:
// renders the ground truth of a scene file (sim/world/) and writes it as float EXR files
// plus PNG previews. The work is in RunSimRender so that tests can call it directly.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}

namespace relume::app {

struct SimRenderQuery {
  std::string scene_path;
  std::string camera;
  std::optional<std::string> time;  // ISO 8601; the scene's time when absent
  std::string out_dir;
  std::optional<int> width;  // both or neither: the camera's size when absent
  std::optional<int> height;
  std::optional<int> sun_samples;
  std::optional<int> sky_samples;
  std::optional<int> indirect_bounces;
};

// Writes radiance.exr (RGB float, W m^-2 sr^-1), depth.exr (metres), normals.exr,
// albedo.exr, sun_visibility.exr, irradiance.exr (W m^-2) and a PNG preview of each
// (radiance tone-mapped and sRGB-encoded; the others scaled to [0, 255]). NaN (no surface)
// is stored as NaN in EXR and black in PNG. Prints a one-line summary. Throws relume::Error.
void RunSimRender(const SimRenderQuery& query, std::ostream& out);

// Adds the `sim` command (with its `render` subcommand) to the CLI.
void AddSimCommand(CLI::App& app);

}  // namespace relume::app
