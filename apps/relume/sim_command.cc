#include "apps/relume/sim_command.h"

#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>
#include <memory>

#include "core/error.h"
#include "sim/world/scene_yaml.h"
#include "sim/world/truth_files.h"
#include "sim/world/world.h"

namespace relume::app {

void RunSimRender(const SimRenderQuery& query, std::ostream& out) {
  if (query.width.has_value() != query.height.has_value()) {
    throw InvalidArgumentError("relume sim render: give both --width and --height, or neither");
  }
  sim::Scene scene = sim::LoadScene(query.scene_path);
  sim::RenderOptions options = scene.render;
  if (query.sun_samples) options.sun_samples = *query.sun_samples;
  if (query.sky_samples) options.sky_samples = *query.sky_samples;
  if (query.indirect_bounces) options.indirect_bounces = *query.indirect_bounces;
  const UtcTime time = query.time ? ParseIso8601(*query.time).utc : scene.time;
  const sim::World world(std::move(scene), options);
  const PinholeCamera camera =
      query.width ? world.Camera(query.camera, *query.width, *query.height) : world.Camera(query.camera);

  const auto start = std::chrono::steady_clock::now();
  const sim::GroundTruth truth = world.Render(camera, time);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  sim::WriteGroundTruth(truth, query.out_dir);

  out << "rendered " << world.scene().name << " camera " << query.camera << " " << camera.intrinsics.width << "x"
      << camera.intrinsics.height << " at " << FormatIso8601(time) << " in " << seconds << " s (sun samples "
      << options.sun_samples << ", sky samples " << options.sky_samples << ", bounces " << options.indirect_bounces
      << ") -> " << query.out_dir << "\n";
}

void AddSimCommand(CLI::App& app) {
  CLI::App* sim = app.add_subcommand("sim", "The simulated world: render ground truth of a scene");
  sim->require_subcommand(1);
  auto query = std::make_shared<SimRenderQuery>();
  CLI::App* render = sim->add_subcommand("render", "Render a scene's ground truth (EXR + PNG previews)");
  render->add_option("scene", query->scene_path, "Scene file (config/scenes/*.yaml)")->required();
  render->add_option("--camera", query->camera, "Named camera of the scene")->required();
  render->add_option("--time", query->time, "UTC instant, ISO 8601 (default: the scene's time)");
  render->add_option("--out", query->out_dir, "Output folder")->required();
  render->add_option("--width", query->width, "Image width (keeps the camera's horizontal FOV)");
  render->add_option("--height", query->height, "Image height");
  render->add_option("--sun-samples", query->sun_samples, "Points on the sun's disk");
  render->add_option("--sky-samples", query->sky_samples, "Sky hemisphere rays per pixel");
  render->add_option("--bounces", query->indirect_bounces, "Diffuse indirect bounces");
  render->callback([query]() { RunSimRender(*query, std::cout); });
}

}  // namespace relume::app
