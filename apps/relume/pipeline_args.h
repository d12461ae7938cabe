// The pipeline options `relume process` and `relume batch` share (--pipeline, --source, --target,
// --mesh, --target-light, --set KEY=VALUE, --force): declared and parsed in one place, so both
// commands take the same flags and a batch runs each session as `relume process` would.
#pragma once

#include <string>
#include <vector>

#include "pipeline/pipeline.h"

namespace CLI {
class App;
}

namespace relume::app {

struct PipelineArgs {
  std::string pipeline;
  std::string source;
  std::string target;
  std::string mesh;
  std::string target_light;
  std::vector<std::string> settings;
  bool force = false;
};

void AddPipelineOptions(CLI::App& cmd, PipelineArgs& args);

// The request these options make (session_dir and out_dir left empty). InvalidArgumentError for a
// --set that is not KEY=VALUE.
pipeline::PipelineRequest PipelineRequestFromArgs(const PipelineArgs& args);

}  // namespace relume::app
