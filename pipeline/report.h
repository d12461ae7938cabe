// report.html: one static page (no server, no network) that shows what a session holds and
// what `relume process` made of it: the session's timeline (frames by device against the sun's
// elevation, faults and other events), its calibrations (with response plots and the chart
// fit), and for each pipeline its planner decisions, measured figures (errors against the
// simulated truth where known) and output images. Images are files beside the page, linked by
// relative paths; figures are inline SVG. The page marks itself when loaded (body attributes
// data-images-loaded / data-images-broken), which the headless-Chromium test reads.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "capture/session.h"

namespace relume::pipeline {

struct PipelineReport {
  std::string name;
  std::filesystem::path out_dir;  // where the pipeline wrote (outputs are relative to it)
  nlohmann::json summary;         // summary.json content; null when the pipeline did not run
  std::string error;              // why it did not run, when it did not
};

// Writes <out_dir>/report.html (and report/ with the plots it draws) and returns its path.
std::filesystem::path WriteReport(const capture::SessionReader& session, const std::filesystem::path& out_dir,
                                  const std::vector<PipelineReport>& pipelines);

}  // namespace relume::pipeline
