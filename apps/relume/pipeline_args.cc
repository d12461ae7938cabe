#include "apps/relume/pipeline_args.h"

#include <CLI/CLI.hpp>

#include "core/error.h"

namespace relume::app {

void AddPipelineOptions(CLI::App& cmd, PipelineArgs& args) {
  cmd.add_option("--pipeline", args.pipeline, "Pipeline to run (--list names them; default: all of them)");
  cmd.add_option("--source", args.source, "Source frames: id, a range of ids 3-12, bracket:N, DEVICE:STREAM or all");
  cmd.add_option("--target", args.target, "Target frames: id, bracket:N, DEVICE:STREAM or all");
  cmd.add_option("--mesh", args.mesh, "Scene geometry when the session did not record it");
  cmd.add_option("--target-light", args.target_light, "Destination lighting: frame selector, SH .json or env map");
  // One value per --set, so that a session folder after it is not taken for a knob.
  cmd.add_option("--set", args.settings, "A pipeline knob, KEY=VALUE (repeatable)")->allow_extra_args(false);
  cmd.add_flag("--force", args.force, "Recompute every stage, even unchanged ones");
}

pipeline::PipelineRequest PipelineRequestFromArgs(const PipelineArgs& args) {
  pipeline::PipelineRequest request;
  request.pipeline = args.pipeline;
  if (!args.source.empty()) request.source = args.source;
  if (!args.target.empty()) request.target = args.target;
  if (!args.mesh.empty()) request.mesh = args.mesh;
  if (!args.target_light.empty()) request.target_light = args.target_light;
  for (const std::string& kv : args.settings) {
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InvalidArgumentError("--set " + kv + ": expected KEY=VALUE (e.g. --set sh_order=1)");
    }
    request.settings[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  request.reuse = !args.force;
  return request;
}

}  // namespace relume::app
