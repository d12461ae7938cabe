// Processing a whole session, as `relume process` does: one pipeline or every pipeline of the
// build, then report.html. The library call the CLI, a batch job or a Python binding makes; the
// CLI only parses arguments and prints what this returns.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"
#include "pipeline/report.h"

namespace relume::pipeline {

struct ProcessResult {
  std::vector<PipelineReport> reports;  // in the order run; a pipeline that did not run says why
  std::filesystem::path report;         // report.html; empty with `explain`
  std::vector<std::string> failed;      // pipelines that failed with an error other than "cannot run here"
};

// Checks the settings (CheckSettings), prepares and locks request.out_dir, then runs
// request.pipeline into it, or, when that is empty or "all", every pipeline into
// out_dir/<name>/: one that cannot run on this session (InvalidArgumentError) or fails is
// recorded with why and the others go on. Writes report.html unless `explain`. `on_done` (may be
// empty) is called after each pipeline with its report, e.g. to print it. A single pipeline's
// error is thrown, as RunPipeline's.
ProcessResult ProcessSession(const PipelineRequest& request,
                             const std::function<void(const PipelineReport&)>& on_done = {});

}  // namespace relume::pipeline
