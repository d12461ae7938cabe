// Shared pieces of `relume bench` (apps/relume/bench_command.cc): one Row per measured
// setting, the timer, and one function per stage. Every stage runs library code on a scene
// whose truth is known (calibration/testing, processing/testing, processing/irm/testing_scene.h,
// processing/radiosity/test_room.h) and computes its error against that truth in the run.
#pragma once

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

namespace relume::app::bench {

struct Row {
  std::string stage;
  std::string method;
  std::string knobs;
  double seconds = 0.0;     // per run (best of the repeats)
  double throughput = 0.0;  // items per second (MP/s for images, positions/s for the sun, ...)
  std::string throughput_unit;
  double error = 0.0;  // the row's headline error, named by error_metric
  std::string error_metric;
  std::string notes;  // further figures of the same run (other error metrics, counts)
};

template <typename F>
double BestSeconds(int repeats, F&& f) {
  double best = 1e300;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return best;
}

std::string Format(double v);

// One function per stage; each appends its rows.
void BenchHdr(bool quick, std::vector<Row>& rows);
void BenchHdrFiles(bool quick, std::vector<Row>& rows);  // end to end from files, relume vs OpenCV
void BenchSun(bool quick, std::vector<Row>& rows);
void BenchSh(bool quick, std::vector<Row>& rows);
void BenchIrm(bool quick, std::vector<Row>& rows);
void BenchRadiosity(bool quick, std::vector<Row>& rows);
void BenchPlanner(bool quick, std::vector<Row>& rows);

// bench.csv, bench.md and bench-<stage>.svg in `out`; the Markdown table is returned.
std::string WriteOutputs(const std::string& out, const std::vector<Row>& rows);

}  // namespace relume::app::bench
