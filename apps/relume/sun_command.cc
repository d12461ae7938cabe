#include "apps/relume/sun_command.h"

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string_view>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "core/input_file.h"
#include "core/sun/sun_track.h"
#include "core/yaml_file.h"

namespace relume::app {

namespace {

std::string Fixed(double value, int digits) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::fixed, digits);
  return std::string(buffer, result.ptr);
}

Site SiteFromQuery(const SunQuery& query) {
  if (!query.latitude_deg || !query.longitude_deg) {
    throw InvalidArgumentError("relume sun: --lat and --lon are required (degrees, north and east positive)");
  }
  return Site::FromDegrees(*query.latitude_deg, *query.longitude_deg, query.height_m);
}

std::string FormatEvent(const std::optional<UtcTime>& time, std::chrono::seconds offset) {
  return time ? FormatIso8601(*time, offset, 0) : std::string("none");
}

std::string DeltaTSource(const SunOptions& options) {
  return std::isnan(options.delta_t_s) ? "Espenak & Meeus model" : "given";
}

}  // namespace

void RunSunSingle(const SunQuery& query, std::ostream& out) {
  const Site site = SiteFromQuery(query);
  if (!query.time) throw InvalidArgumentError("relume sun: --time is required (ISO 8601, e.g. 2024-06-21T12:00:00Z)");
  const ParsedTime parsed = ParseIso8601(*query.time);
  const SunPosition sun = ComputeSunPosition(site, parsed.utc, query.options);
  const UtcTime local_midnight_reference = parsed.utc + parsed.utc_offset;
  const CivilDate local_date =
      CivilFromDays(std::chrono::floor<std::chrono::days>(local_midnight_reference).time_since_epoch().count());
  const SunDayEvents day = ComputeSunDayEvents(site, local_date, parsed.utc_offset, query.options);

  if (query.json) {
    nlohmann::json j;
    j["algorithm"] = kSunAlgorithmName;
    j["site"] = {
        {"latitude_deg", site.latitude_deg()}, {"longitude_deg", site.longitude_deg()}, {"height_m", site.height_m}};
    j["time_utc"] = FormatIso8601(parsed.utc, std::chrono::seconds{0}, 3);
    j["time_local"] = FormatIso8601(parsed.utc, parsed.utc_offset, 3);
    j["elevation_deg"] = RadToDeg(sun.elevation_rad);
    j["elevation_geometric_deg"] = RadToDeg(sun.elevation_geometric_rad);
    j["refraction_deg"] = RadToDeg(sun.refraction_rad);
    j["azimuth_deg"] = RadToDeg(sun.azimuth_rad);
    j["zenith_deg"] = RadToDeg(sun.zenith_rad);
    j["declination_deg"] = RadToDeg(sun.declination_rad);
    j["right_ascension_deg"] = RadToDeg(sun.right_ascension_rad);
    j["hour_angle_deg"] = RadToDeg(sun.hour_angle_rad);
    j["distance_au"] = sun.distance_au;
    j["delta_t_s"] = sun.delta_t_s;
    j["delta_t_source"] = DeltaTSource(query.options);
    j["dut1_s"] = query.options.dut1_s;
    j["pressure_hpa"] = query.options.pressure_hpa;
    j["temperature_c"] = query.options.temperature_c;
    auto event = [&](const std::optional<UtcTime>& t) {
      return t ? nlohmann::json(FormatIso8601(*t, parsed.utc_offset, 0)) : nlohmann::json(nullptr);
    };
    j["day"] = {{"kind", ToString(day.kind)},
                {"sunrise", event(day.sunrise)},
                {"transit", event(day.transit)},
                {"sunset", event(day.sunset)},
                {"transit_elevation_deg", RadToDeg(day.transit_elevation_rad)}};
    out << j.dump(2) << "\n";
    return;
  }
  out << "site          " << Fixed(site.latitude_deg(), 6) << " deg N, " << Fixed(site.longitude_deg(), 6) << " deg E, "
      << Fixed(site.height_m, 1) << " m\n";
  out << "time          " << FormatIso8601(parsed.utc, parsed.utc_offset, 3) << " ("
      << FormatIso8601(parsed.utc, std::chrono::seconds{0}, 3) << ")\n";
  out << "elevation     " << Fixed(RadToDeg(sun.elevation_rad), 6) << " deg (geometric "
      << Fixed(RadToDeg(sun.elevation_geometric_rad), 6) << ", refraction " << Fixed(RadToDeg(sun.refraction_rad), 6)
      << ")\n";
  out << "azimuth       " << Fixed(RadToDeg(sun.azimuth_rad), 6) << " deg (from true north, eastward)\n";
  out << "zenith        " << Fixed(RadToDeg(sun.zenith_rad), 6) << " deg\n";
  out << "sunrise       " << FormatEvent(day.sunrise, parsed.utc_offset) << "\n";
  out << "transit       " << FormatEvent(day.transit, parsed.utc_offset) << " (elevation "
      << Fixed(RadToDeg(day.transit_elevation_rad), 4) << " deg)\n";
  out << "sunset        " << FormatEvent(day.sunset, parsed.utc_offset) << "\n";
  if (day.kind != SunDayKind::kNormal) out << "day           " << ToString(day.kind) << "\n";
  out << "delta_t       " << Fixed(sun.delta_t_s, 2) << " s (" << DeltaTSource(query.options) << "), dut1 "
      << Fixed(query.options.dut1_s, 3) << " s, algorithm " << kSunAlgorithmName << "\n";
}

namespace {

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      cells.push_back(cell);
      cell.clear();
    } else if (c != '\r') {
      cell.push_back(c);
    }
  }
  cells.push_back(cell);
  for (std::string& s : cells) {
    const auto first = s.find_first_not_of(" \t");
    const auto last = s.find_last_not_of(" \t");
    s = first == std::string::npos ? std::string() : s.substr(first, last - first + 1);
  }
  return cells;
}

// Column names accepted for each input, in order of preference.
enum Column { kTime, kLat, kLon, kHeight, kDeltaT, kPressure, kTemperature, kColumnCount };
const std::vector<std::vector<std::string>> kColumnNames = {{"time"},
                                                            {"lat", "latitude", "latitude_deg"},
                                                            {"lon", "longitude", "longitude_deg"},
                                                            {"height", "height_m"},
                                                            {"delta_t", "delta_t_s"},
                                                            {"pressure", "pressure_hpa"},
                                                            {"temperature", "temperature_c"}};

struct SiteKey {
  double lat, lon, height, delta_t, pressure, temperature;
  auto Tie() const { return std::tie(lat, lon, height, delta_t, pressure, temperature); }
  bool operator<(const SiteKey& other) const {
    // NaN delta_t (model) compares via its bit pattern-free stand-in below.
    return Tie() < other.Tie();
  }
};

constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";

// A NUL byte is never text: it would silently cut a column name or a value short.
void RejectNul(const std::string& line, const std::string& source_name, int line_number) {
  const std::size_t at = line.find('\0');
  if (at != std::string::npos) {
    throw ConfigError(source_name, line_number, "",
                      "a NUL byte at column " + std::to_string(at + 1) + " (is this a text CSV file?)");
  }
}

constexpr const char* kCsvHeader =
    "time,latitude_deg,longitude_deg,height_m,elevation_deg,azimuth_deg,zenith_deg,elevation_geometric_deg,"
    "declination_deg,hour_angle_deg,distance_au,delta_t_s\n";

void AppendCsvRow(std::string& buffer, UtcTime time, const Site& site, const SunPosition& sun) {
  buffer += FormatIso8601(time, std::chrono::seconds{0}, 3);
  for (double v : {site.latitude_deg(), site.longitude_deg(), site.height_m, RadToDeg(sun.elevation_rad),
                   RadToDeg(sun.azimuth_rad), RadToDeg(sun.zenith_rad), RadToDeg(sun.elevation_geometric_rad),
                   RadToDeg(sun.declination_rad), RadToDeg(sun.hour_angle_rad)}) {
    buffer += ',';
    buffer += Fixed(v, 6);
  }
  buffer += ',';
  buffer += Fixed(sun.distance_au, 8);
  buffer += ',';
  buffer += Fixed(sun.delta_t_s, 3);
  buffer += '\n';
}

}  // namespace

std::size_t RunSunSeries(const SunQuery& query, std::ostream& out) {
  const Site site = SiteFromQuery(query);
  if (!query.time || !query.until) throw InvalidArgumentError("relume sun: a series needs --time (start) and --until");
  const UtcTime start = ParseIso8601(*query.time).utc;
  const UtcTime end = ParseIso8601(*query.until).utc;
  if (!(query.step_s >= 1e-3 && query.step_s <= 86400.0 * 366)) {
    throw InvalidArgumentError("relume sun: --step must be within [0.001, 31622400] seconds");
  }
  if (end < start) throw InvalidArgumentError("relume sun: --until is before --time");
  const auto step = std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(query.step_s));
  // UtcTime spans 585 years of int64 nanoseconds, so `end - start` overflows for series longer
  // than 292 years: the span is taken as unsigned, where every difference end >= start fits.
  const std::uint64_t span_ns = static_cast<std::uint64_t>(end.time_since_epoch().count()) -
                                static_cast<std::uint64_t>(start.time_since_epoch().count());
  const std::uint64_t rows = span_ns / static_cast<std::uint64_t>(step.count()) + 1;
  constexpr std::uint64_t kMaxRows = 100'000'000;
  if (rows > kMaxRows) {
    throw InvalidArgumentError("relume sun: the series would have " + std::to_string(rows) +
                               " rows (more than 100 million); use a larger --step");
  }
  const auto count = static_cast<std::int64_t>(rows);
  SunTrackOptions options;
  options.sun = query.options;
  SunTrack track(site, options);
  out << kCsvHeader;
  std::string buffer;
  UtcTime t = start;
  for (std::int64_t i = 0; i < count; ++i) {
    if (i > 0) t += step;  // stepped, not start + step * i: that product overflows like the span
    buffer.clear();
    AppendCsvRow(buffer, t, site, track.At(t));
    out << buffer;
  }
  return static_cast<std::size_t>(count);
}

namespace {

// Where each input column is in the file (-1: absent), and how many cells the header has.
struct CsvColumns {
  std::size_t header_cells = 0;
  int index[kColumnCount];
};

// The header line (the first that is not blank): which columns the file has. "time" is required,
// and lat/lon unless --lat/--lon give them. Counts the lines read in `line_number`.
CsvColumns ReadSunCsvHeader(const SunQuery& query, std::istream& in, const std::string& source_name, int* line_number) {
  std::string line;
  while (std::getline(in, line)) {
    ++*line_number;
    if (line.find_first_not_of(" \t\r") != std::string::npos) break;
  }
  if (*line_number == 0 || line.find_first_not_of(" \t\r") == std::string::npos) {
    throw ConfigError(source_name, *line_number, "",
                      "empty CSV: expected a header line naming the columns (time, lat, lon, ...)");
  }
  if (line.rfind(kUtf8Bom, 0) == 0) line.erase(0, kUtf8Bom.size());  // spreadsheets write one
  RejectNul(line, source_name, *line_number);
  const std::vector<std::string> header = SplitCsvLine(line);
  CsvColumns columns;
  columns.header_cells = header.size();
  for (int c = 0; c < kColumnCount; ++c) {
    columns.index[c] = -1;
    for (std::size_t h = 0; h < header.size() && columns.index[c] < 0; ++h) {
      for (const std::string& name : kColumnNames[static_cast<std::size_t>(c)]) {
        if (header[h] == name) columns.index[c] = static_cast<int>(h);
      }
    }
  }
  if (columns.index[kTime] < 0) {
    throw ConfigError(source_name, *line_number, "time", "the header has no 'time' column (ISO 8601 with a zone)");
  }
  if ((columns.index[kLat] < 0 && !query.latitude_deg) || (columns.index[kLon] < 0 && !query.longitude_deg)) {
    throw ConfigError(source_name, *line_number, "lat/lon",
                      "no 'lat'/'lon' columns and no --lat/--lon flags: the site is unknown");
  }
  return columns;
}

// One data row's cells by column; errors name the file, the line and the column.
class SunCsvRow {
 public:
  SunCsvRow(std::vector<std::string> cells, const CsvColumns& columns, const std::string& source_name, int line_number)
      : cells_(std::move(cells)), columns_(columns), source_name_(source_name), line_number_(line_number) {}

  // The column's cell, or null when the file has no such column or the cell is empty.
  const std::string* Cell(Column c) const {
    const int index = columns_.index[c];
    if (index < 0 || static_cast<std::size_t>(index) >= cells_.size() ||
        cells_[static_cast<std::size_t>(index)].empty()) {
      return nullptr;
    }
    return &cells_[static_cast<std::size_t>(index)];
  }

  // The column's number, or `fallback` (a flag's value) when the cell is empty.
  double Number(Column c, std::optional<double> fallback) const {
    const std::string* text = Cell(c);
    if (!text) {
      if (fallback) return *fallback;
      throw ConfigError(source_name_, line_number_, kColumnNames[c][0], "value missing and no flag gives a default");
    }
    double value = 0.0;
    const auto result = std::from_chars(text->data(), text->data() + text->size(), value);
    if (result.ec != std::errc() || result.ptr != text->data() + text->size() || !std::isfinite(value)) {
      throw ConfigError(source_name_, line_number_, kColumnNames[c][0], "'" + *text + "' is not a finite number");
    }
    return value;
  }

  const std::string& source_name() const { return source_name_; }
  int line_number() const { return line_number_; }

 private:
  std::vector<std::string> cells_;
  const CsvColumns& columns_;
  const std::string& source_name_;
  int line_number_;
};

// The sun for one data row, appended to `buffer` as a CSV row: the row's time, its site and
// atmosphere from its cells or the flags. `tracks` holds one SunTrack per distinct site and
// atmosphere, so that series of rows reuse the slowly varying terms. Bounded: a file with a new
// site on every row falls back to fresh tracks.
void AppendSunRow(const SunQuery& query, const SunCsvRow& row, std::map<SiteKey, std::unique_ptr<SunTrack>>* tracks,
                  std::string& buffer) {
  const std::string& source_name = row.source_name();
  const int line_number = row.line_number();
  const std::string* time_text = row.Cell(kTime);
  if (!time_text) throw ConfigError(source_name, line_number, "time", "value missing");
  const UtcTime time = ParseIso8601(*time_text).utc;
  SunTrackOptions options;
  options.sun = query.options;
  const std::optional<double> default_delta_t =
      std::isnan(query.options.delta_t_s) ? std::nullopt : std::optional<double>(query.options.delta_t_s);
  options.sun.delta_t_s =
      row.Cell(kDeltaT) ? row.Number(kDeltaT, std::nullopt) : (default_delta_t ? *default_delta_t : NAN);
  options.sun.pressure_hpa = row.Number(kPressure, query.options.pressure_hpa);
  options.sun.temperature_c = row.Number(kTemperature, query.options.temperature_c);
  const Site site{DegToRad(row.Number(kLat, query.latitude_deg)), DegToRad(row.Number(kLon, query.longitude_deg)),
                  row.Number(kHeight, query.height_m)};
  std::string why;
  if (!site.IsValid(&why)) throw ConfigError(source_name, line_number, "site", why);
  if (!options.sun.IsValid(&why)) throw ConfigError(source_name, line_number, "options", why);

  const SiteKey key{site.latitude_rad,
                    site.longitude_rad,
                    site.height_m,
                    std::isnan(options.sun.delta_t_s) ? -1e300 : options.sun.delta_t_s,
                    options.sun.pressure_hpa,
                    options.sun.temperature_c};
  auto it = tracks->find(key);
  if (it == tracks->end()) {
    if (tracks->size() >= 256) tracks->clear();
    it = tracks->emplace(key, std::make_unique<SunTrack>(site, options)).first;
  }
  const SunPosition sun = it->second->At(time);
  AppendCsvRow(buffer, time, site, sun);
}

}  // namespace

std::size_t RunSunCsv(const SunQuery& query, std::istream& in, const std::string& source_name, std::ostream& out) {
  int line_number = 0;
  const CsvColumns columns = ReadSunCsvHeader(query, in, source_name, &line_number);
  out << kCsvHeader;
  std::map<SiteKey, std::unique_ptr<SunTrack>> tracks;
  std::string line;
  std::string buffer;
  std::size_t rows = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    RejectNul(line, source_name, line_number);
    std::vector<std::string> cells = SplitCsvLine(line);
    if (cells.size() < columns.header_cells) {
      // A short row would otherwise take the flags' values for its missing cells, silently.
      throw ConfigError(source_name, line_number, "",
                        "the row has " + std::to_string(cells.size()) + " cells, the header " +
                            std::to_string(columns.header_cells) + " (leave a cell empty to take the flag's value)");
    }
    const SunCsvRow row(std::move(cells), columns, source_name, line_number);
    try {
      buffer.clear();
      AppendSunRow(query, row, &tracks, buffer);
      out << buffer;
      ++rows;
    } catch (const ConfigError&) {
      throw;
    } catch (const Error& e) {
      throw ConfigError(source_name, line_number, "", e.what());
    }
  }
  return rows;
}

void AddSunCommand(CLI::App& app) {
  auto query = std::make_shared<SunQuery>();
  auto site_path = std::make_shared<std::string>();
  CLI::App* sun = app.add_subcommand("sun", "Sun position (NREL SPA) and sunrise/transit/sunset at a site");
  CLI::Option* lat = sun->add_option("--lat", query->latitude_deg, "Latitude in degrees, north positive (WGS84)");
  CLI::Option* lon = sun->add_option("--lon", query->longitude_deg, "Longitude in degrees, east positive");
  CLI::Option* height =
      sun->add_option("--height", query->height_m, "Height above the WGS84 ellipsoid in metres")->capture_default_str();
  sun->add_option("--site", *site_path, "A site file (config/sites/*.yaml) instead of --lat/--lon/--height")
      ->excludes(lat)
      ->excludes(lon)
      ->excludes(height);
  sun->add_option("--time", query->time, "ISO 8601 time with a zone, e.g. 2024-06-21T12:00:00+02:00");
  sun->add_option("--pressure", query->options.pressure_hpa, "Air pressure in hPa (0 = no refraction)")
      ->capture_default_str();
  sun->add_option("--temperature", query->options.temperature_c, "Air temperature in deg C")->capture_default_str();
  sun->add_option("--delta-t", query->options.delta_t_s, "TT - UT1 in seconds (default: Espenak & Meeus model)");
  sun->add_option("--dut1", query->options.dut1_s, "UT1 - UTC in seconds (IERS Bulletin A)")->capture_default_str();
  sun->add_flag("--json", query->json, "Write JSON instead of text");
  sun->add_option("--csv", query->csv_path,
                  "Batch mode: a CSV file (or - for standard input) with a header naming its columns: time, lat, lon, "
                  "height, delta_t, pressure, temperature; missing columns take the flags' values");
  sun->add_option("--until", query->until, "Series mode: write the sun from --time until this time, as CSV");
  sun->add_option("--step", query->step_s, "Series mode: seconds between rows")->capture_default_str();
  sun->callback([query, site_path]() {
    if (!site_path->empty()) {
      const SiteConfig config = LoadSiteConfig(*site_path);
      query->latitude_deg = config.site.latitude_deg();
      query->longitude_deg = config.site.longitude_deg();
      query->height_m = config.site.height_m;
    }
    if (query->until) {
      RunSunSeries(*query, std::cout);
      return;
    }
    if (!query->csv_path) {
      RunSunSingle(*query, std::cout);
      return;
    }
    if (*query->csv_path == "-") {
      RunSunCsv(*query, std::cin, "<stdin>", std::cout);
      return;
    }
    std::ifstream file = OpenInputFile(*query->csv_path);
    RunSunCsv(*query, file, *query->csv_path, std::cout);
  });
}

}  // namespace relume::app
