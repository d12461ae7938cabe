// `relume sun`: the sun's position and the day's rise/transit/set for one instant, or for
// every row of a CSV (batch mode). The parsing and formatting live here, not in main(), so
// that tests can run them directly.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "core/sun/sun_position.h"

namespace CLI {
class App;
}

namespace relume::app {

// Values given as flags; in batch mode they fill CSV columns that are absent or empty.
struct SunQuery {
  std::optional<double> latitude_deg;
  std::optional<double> longitude_deg;
  double height_m = 0.0;
  std::optional<std::string> time;
  SunOptions options;  // delta_t NaN = model
  bool json = false;
  std::optional<std::string> csv_path;  // "-" = standard input
  std::optional<std::string> until;     // series mode: from `time` to `until` ...
  double step_s = 60.0;                 // ... every step_s seconds
};

// One instant: writes a text (or JSON) report. Throws relume::Error on bad input.
void RunSunSingle(const SunQuery& query, std::ostream& out);

// Batch: reads a CSV with a header naming its columns (time, lat, lon, height, delta_t,
// pressure, temperature; others are ignored), writes one CSV row per input row. A bad row
// throws ConfigError naming `source_name`, its line number and what is wrong. Returns the
// number of rows written.
std::size_t RunSunCsv(const SunQuery& query, std::istream& in, const std::string& source_name, std::ostream& out);

// Series: the sun at time, time + step, ... up to and including `until`, as the same CSV
// columns as batch mode, through the time-series path (SunTrack). Returns the row count.
std::size_t RunSunSeries(const SunQuery& query, std::ostream& out);

// Adds the `sun` subcommand to the CLI.
void AddSunCommand(CLI::App& app);

}  // namespace relume::app
