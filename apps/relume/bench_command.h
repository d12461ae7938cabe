// `relume bench [--stage hdr|sun|all] [--quick] [--out DIR]`: run time against error on inputs
// whose truth is known, with the independent peer beside relume's method (OpenCV's
// CalibrateDebevec + MergeDebevec for HDR; per-call SPA for the sun's time-series path).
// Writes bench.csv, bench.md and one SVG plot per stage (run time against error).
#pragma once

namespace CLI {
class App;
}

namespace relume::app {

void AddBenchCommand(CLI::App& app);

}  // namespace relume::app
