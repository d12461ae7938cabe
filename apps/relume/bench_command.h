// `relume bench [--stage hdr|sun|sh|irm|radiosity|planner|all] [--quick] [--out DIR]`: run time
// against error on inputs whose truth is known, for every processing stage across its quality
// knobs, with the independent peer beside relume's method where there is one (OpenCV's
// CalibrateDebevec + MergeDebevec for HDR; per-call SPA for the sun's time-series path), and
// the stage planner's skips timed with and without (forced). Writes bench.csv, bench.md and one
// SVG plot per stage (run time against error). The stages live in apps/relume/bench/.
#pragma once

namespace CLI {
class App;
}

namespace relume::app {

void AddBenchCommand(CLI::App& app);

}  // namespace relume::app
