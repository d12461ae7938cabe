#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "apps/relume/bench/bench.h"

namespace relume::app::bench {

std::string Format(double v) {
  std::ostringstream s;
  s << std::setprecision(4) << v;
  return s.str();
}
namespace {

namespace fs = std::filesystem;

// Run time (log x) against error (log y), one colour per method.
std::string PlotSvg(const std::string& stage, const std::vector<Row>& rows) {
  std::vector<const Row*> mine;
  for (const Row& r : rows) {
    if (r.stage == stage) mine.push_back(&r);
  }
  const int w = 720, h = 420, left = 70, right = 260, top = 20, bottom = 50;
  double t0 = 1e300, t1 = 0, e0 = 1e300, e1 = 0;
  for (const Row* r : mine) {
    t0 = std::min(t0, r->seconds);
    t1 = std::max(t1, r->seconds);
    const double e = std::max(r->error, 1e-12);
    e0 = std::min(e0, e);
    e1 = std::max(e1, e);
  }
  const double lt0 = std::floor(std::log10(t0)), lt1 = std::ceil(std::log10(t1)) + (t0 == t1 ? 1 : 0);
  const double le0 = std::floor(std::log10(e0)), le1 = std::ceil(std::log10(e1)) + (e0 == e1 ? 1 : 0);
  auto x = [&](double t) { return left + (std::log10(t) - lt0) / (lt1 - lt0) * (w - left - right); };
  auto y = [&](double e) { return top + (le1 - std::log10(std::max(e, 1e-12))) / (le1 - le0) * (h - top - bottom); };
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h << "\">\n"
      << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << w - left - right << "\" height=\""
      << h - top - bottom << "\" fill=\"#fafafa\" stroke=\"#ccc\"/>\n";
  for (double d = lt0; d <= lt1; d += 1) {
    svg << "<text x=\"" << x(std::pow(10, d)) << "\" y=\"" << h - bottom + 16
        << "\" font-size=\"11\" text-anchor=\"middle\">1e" << d << " s</text>\n";
  }
  for (double d = le0; d <= le1; d += 1) {
    svg << "<text x=\"" << left - 6 << "\" y=\"" << y(std::pow(10, d)) + 4
        << "\" font-size=\"11\" text-anchor=\"end\">1e" << d << "</text>\n";
  }
  svg << "<text x=\"" << (left + w - right) / 2 << "\" y=\"" << h - 10
      << "\" font-size=\"12\" text-anchor=\"middle\">run time per call (s)</text>\n";
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
  std::vector<std::string> methods;
  for (const Row* r : mine) {
    if (std::find(methods.begin(), methods.end(), r->method) == methods.end()) methods.push_back(r->method);
  }
  for (const Row* r : mine) {
    const auto index = std::find(methods.begin(), methods.end(), r->method) - methods.begin();
    svg << "<circle cx=\"" << x(r->seconds) << "\" cy=\"" << y(r->error) << "\" r=\"4\" fill=\"" << colours[index % 4]
        << "\"><title>" << r->method << ", " << r->knobs << ": " << Format(r->seconds) << " s, " << Format(r->error)
        << "</title></circle>\n";
  }
  for (std::size_t i = 0; i < methods.size(); ++i) {
    svg << "<circle cx=\"" << w - right + 14 << "\" cy=\"" << top + 10 + 16 * i << "\" r=\"4\" fill=\""
        << colours[i % 4] << "\"/><text x=\"" << w - right + 22 << "\" y=\"" << top + 14 + 16 * i
        << "\" font-size=\"11\">" << methods[i] << "</text>\n";
  }
  svg << "<text x=\"" << w - right + 8 << "\" y=\"" << h - bottom
      << "\" font-size=\"11\">y: " << (mine.empty() ? "" : mine.front()->error_metric) << "</text>\n</svg>\n";
  return svg.str();
}

}  // namespace

std::string WriteOutputs(const std::string& out, const std::vector<Row>& rows) {
  fs::create_directories(out);
  std::ofstream csv(fs::path(out) / "bench.csv");
  std::ostringstream md;
  csv << "stage,method,knobs,seconds,throughput,throughput_unit,error,error_metric,notes\n";
  md << "| stage | method | knobs | time per call (s) | throughput | error | notes |\n|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    csv << r.stage << ",\"" << r.method << "\",\"" << r.knobs << "\"," << std::setprecision(9) << r.seconds << ","
        << r.throughput << "," << r.throughput_unit << "," << r.error << ",\"" << r.error_metric << "\",\"" << r.notes
        << "\"\n";
    md << "| " << r.stage << " | " << r.method << " | " << r.knobs << " | " << Format(r.seconds) << " | "
       << Format(r.throughput) << " " << r.throughput_unit << " | " << Format(r.error) << " (" << r.error_metric
       << ") | " << r.notes << " |\n";
  }
  std::vector<std::string> stages;
  for (const Row& r : rows) {
    if (std::find(stages.begin(), stages.end(), r.stage) == stages.end()) stages.push_back(r.stage);
  }
  for (const std::string& stage : stages)
    std::ofstream(fs::path(out) / ("bench-" + stage + ".svg")) << PlotSvg(stage, rows);
  std::ofstream(fs::path(out) / "bench.md") << md.str();
  return md.str();
}

}  // namespace relume::app::bench
