#include "pipeline/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <sstream>

#include "calibration/calibration_profile.h"
#include "calibration/image_file.h"
#include "calibration/report_plots.h"
#include "capture/durable_file.h"
#include "capture/rgbd_geometry.h"
#include "core/error.h"
#include "pipeline/pipeline.h"

namespace relume::pipeline {
namespace fs = std::filesystem;

namespace {

std::string Escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

const char* const kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf"};

// Frames by device against the sun's elevation over the session's time, events as ticks.
std::string TimelineSvg(const std::vector<capture::FrameRecord>& frames,
                        const std::vector<capture::EventRecord>& events) {
  if (frames.empty()) return "<p>No frames.</p>";
  const double t0 = static_cast<double>(frames.front().utc.time_since_epoch().count()) * 1e-9;
  double t1 = t0;
  double el_min = 0.0, el_max = 10.0;
  for (const capture::FrameRecord& f : frames) {
    t1 = std::max(t1, static_cast<double>(f.utc.time_since_epoch().count()) * 1e-9);
    el_min = std::min(el_min, std::floor(f.sun_elevation_deg / 10.0) * 10.0);
    el_max = std::max(el_max, std::ceil(f.sun_elevation_deg / 10.0) * 10.0);
  }
  const double span = std::max(t1 - t0, 1.0);
  const int w = 860, h = 300, left = 60, right = 20, top = 20, bottom = 50;
  auto x_of = [&](double t) { return left + (t - t0) / span * (w - left - right); };
  auto y_of = [&](double el) { return top + (el_max - el) / (el_max - el_min) * (h - top - bottom); };
  std::ostringstream svg;
  svg << "<svg id=\"timeline\" class=\"figure\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\""
      << h << "\" viewBox=\"0 0 " << w << " " << h
      << "\" role=\"img\" aria-label=\"frames and sun elevation over time\">\n";
  svg << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << w - left - right << "\" height=\""
      << h - top - bottom << "\" fill=\"#fafafa\" stroke=\"#ccc\"/>\n";
  for (double el = el_min; el <= el_max + 1e-9; el += 10.0) {
    svg << "<line x1=\"" << left << "\" x2=\"" << w - right << "\" y1=\"" << y_of(el) << "\" y2=\"" << y_of(el)
        << "\" stroke=\"#e4e4e4\"/><text x=\"" << left - 6 << "\" y=\"" << y_of(el) + 4
        << "\" font-size=\"11\" text-anchor=\"end\">" << el << "&#176;</text>\n";
  }
  svg << "<text x=\"14\" y=\"" << (top + h - bottom) / 2 << "\" font-size=\"11\" transform=\"rotate(-90 14 "
      << (top + h - bottom) / 2 << ")\" text-anchor=\"middle\">sun elevation</text>\n";
  for (int k = 0; k <= 4; ++k) {
    const double t = t0 + span * k / 4.0;
    const UtcTime utc{std::chrono::duration_cast<Nanoseconds>(std::chrono::duration<double>(t))};
    svg << "<text x=\"" << x_of(t) << "\" y=\"" << h - bottom + 16 << "\" font-size=\"11\" text-anchor=\"middle\">"
        << Escape(FormatIso8601(utc).substr(11, 8)) << "</text>\n";
  }
  svg << "<text x=\"" << (left + w - right) / 2 << "\" y=\"" << h - 8
      << "\" font-size=\"11\" text-anchor=\"middle\">UTC, " << Escape(FormatIso8601(frames.front().utc).substr(0, 10))
      << "</text>\n";
  std::map<std::string, int> device_index;
  for (const capture::FrameRecord& f : frames) device_index.emplace(f.device_id + " " + f.stream, 0);
  int next = 0;
  for (auto& [name, index] : device_index) index = next++;
  for (const capture::EventRecord& e : events) {
    if (e.type == "note") continue;
    const double t = static_cast<double>(e.utc.time_since_epoch().count()) * 1e-9;
    if (t < t0 - 1 || t > t1 + 1) continue;
    const std::string colour = e.type == "fault" ? "#d62728" : "#999";
    svg << "<line x1=\"" << x_of(t) << "\" x2=\"" << x_of(t) << "\" y1=\"" << top << "\" y2=\"" << h - bottom
        << "\" stroke=\"" << colour << "\" stroke-dasharray=\"3,3\"><title>" << Escape(e.type + ": " + e.message)
        << "</title></line>\n";
  }
  for (const capture::FrameRecord& f : frames) {
    const double t = static_cast<double>(f.utc.time_since_epoch().count()) * 1e-9;
    const int index = device_index[f.device_id + " " + f.stream];
    svg << "<circle cx=\"" << x_of(t) << "\" cy=\"" << y_of(f.sun_elevation_deg) + (index - 1) * 3
        << "\" r=\"3\" fill=\"" << kPalette[index % 7] << "\"><title>frame " << f.id << " " << Escape(f.device_id)
        << " " << f.stream << " " << Escape(FormatIso8601(f.utc)) << " sun " << Fixed(f.sun_elevation_deg, 2)
        << "&#176;</title></circle>\n";
  }
  int row = 0;
  for (const auto& [name, index] : device_index) {
    svg << "<circle cx=\"" << left + 12 << "\" cy=\"" << top + 14 + 14 * row << "\" r=\"4\" fill=\""
        << kPalette[index % 7] << "\"/><text x=\"" << left + 22 << "\" y=\"" << top + 18 + 14 * row
        << "\" font-size=\"11\">" << Escape(name) << "</text>\n";
    ++row;
  }
  svg << "</svg>\n";
  return svg.str();
}

bool IsImage(const fs::path& path) {
  const std::string ext = path.extension().string();
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".svg";
}

// An image that shows an output: itself, or the preview PNG written beside an EXR.
std::optional<fs::path> ShownImage(const fs::path& output) {
  if (IsImage(output)) return output;
  for (const fs::path& candidate :
       {fs::path(output).replace_extension(".png"), output.parent_path() / (output.stem().string() + "_preview.png"),
        output.parent_path() / "preview.png"}) {
    if (fs::exists(candidate)) return candidate;
  }
  return std::nullopt;
}

// The images that show a pipeline's result at a glance: the last relit image of its outputs
// (relit.png, or an SH frame's composite.png) with the source and target previews its stage wrote
// beside it and the error against the truth; else its first preview. Captions say which.
std::vector<std::pair<fs::path, std::string>> KeyImages(const PipelineReport& p) {
  std::vector<std::pair<fs::path, std::string>> images;
  std::optional<fs::path> relit;
  std::optional<fs::path> first;
  for (const nlohmann::json& o : p.summary["outputs"]) {
    const fs::path output = p.out_dir / o.value("path", "");
    const std::string name = output.filename().string();
    if ((name == "relit.png" || name == "composite.png") && fs::exists(output)) relit = output;
    if (!first) {
      const std::optional<fs::path> image = ShownImage(output);
      if (image && fs::exists(*image)) first = image;
    }
  }
  if (!relit) {
    if (first) images.emplace_back(*first, "preview");
    return images;
  }
  const fs::path dir = relit->parent_path();
  if (fs::exists(dir / "source.png")) images.emplace_back(dir / "source.png", "source");
  images.emplace_back(*relit, "relit");
  if (fs::exists(dir / "target.png")) images.emplace_back(dir / "target.png", "target");
  if (fs::exists(p.out_dir / "truth_error.png")) images.emplace_back(p.out_dir / "truth_error.png", "error vs truth");
  return images;
}

// Scalar figures of a metrics object, flattened to "a.b.c" keys (arrays of objects listed by index).
void Flatten(const nlohmann::json& j, const std::string& prefix,
             std::vector<std::pair<std::string, std::string>>& out) {
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) Flatten(value, prefix.empty() ? key : prefix + "." + key, out);
  } else if (j.is_array()) {
    const bool scalars = std::all_of(j.begin(), j.end(), [](const nlohmann::json& v) { return v.is_primitive(); });
    if (scalars && j.size() <= 12) {
      out.emplace_back(prefix, j.dump());
    } else {
      for (std::size_t i = 0; i < j.size() && i < 40; ++i) Flatten(j[i], prefix + "[" + std::to_string(i) + "]", out);
    }
  } else if (j.is_number_float()) {
    const double v = j.get<double>();
    out.emplace_back(prefix, std::fabs(v) >= 1e4 || (std::fabs(v) < 1e-3 && v != 0.0) ? [&] {
      char text[32];
      std::snprintf(text, sizeof(text), "%.4g", v);
      return std::string(text);
    }()
                                                                                        : Fixed(v, 4));
  } else if (j.is_string()) {
    out.emplace_back(prefix, j.get<std::string>());
  } else {
    out.emplace_back(prefix, j.dump());
  }
}

// ---- report sections, in page order ---------------------------------------------------------

void WriteHead(std::ostringstream& html, const capture::SessionInfo& info) {
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>relume report: "
       << Escape(info.name)
       << "</title>\n<script>\nwindow.relumeErrors = 0;\nwindow.addEventListener('error', function () { "
          "window.relumeErrors++; }, true);\n</script>\n<style>\n"
       << "body{font-family:sans-serif;margin:24px;max-width:1380px;color:#222}"
          "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ddd;padding:3px 8px;font-size:13px;"
          "text-align:left;vertical-align:top}th{background:#f3f3f3}figure{display:inline-block;margin:6px;"
          "vertical-align:top}figure img{max-width:420px;border:1px solid #ccc}figcaption{font-size:12px;"
          "max-width:420px}.skip{color:#a60}.run{color:#060}.reuse{color:#06a}.error{color:#b00}"
          "code{font-size:12px}#results img{max-height:130px;max-width:180px;border:1px solid #ccc}"
          "#results td.images{white-space:nowrap}#results td.result{max-width:420px}#results "
          "figure{margin:2px}.blink{cursor:pointer}img.light{max-width:160px}\n</style>\n</head>\n"
          "<body>\n";
}

// The session at a glance: where, which devices, over what time span (first to last frame, with
// the sun's elevation at each end), recorded by what.
void WriteSessionTable(std::ostringstream& html, const capture::SessionReader& session,
                       const capture::SessionInfo& info, const std::vector<capture::FrameRecord>& frames) {
  html << "<h1>relume report: " << Escape(info.name) << "</h1>\n";
  html << "<table id=\"session\"><tr><th>session</th><td>" << Escape(fs::absolute(session.dir()).string())
       << "</td></tr><tr><th>site</th><td>" << Fixed(info.site.latitude_deg(), 6) << "&#176;, "
       << Fixed(info.site.longitude_deg(), 6) << "&#176;, " << Fixed(info.site.height_m, 1) << " m</td></tr>";
  std::string devices;
  for (const drivers::DeviceInfo& d : session.Devices()) devices += (devices.empty() ? "" : ", ") + d.FullId();
  html << "<tr><th>devices</th><td>" << Escape(devices.empty() ? std::string("none") : devices) << "</td></tr>";
  if (!frames.empty()) {
    const auto [first, last] =
        std::minmax_element(frames.begin(), frames.end(), [](const auto& a, const auto& b) { return a.utc < b.utc; });
    html << "<tr><th>frames</th><td>" << frames.size() << ", " << Escape(FormatIso8601(first->utc)) << " (sun "
         << Fixed(first->sun_elevation_deg, 1) << "&#176;) to " << Escape(FormatIso8601(last->utc)) << " (sun "
         << Fixed(last->sun_elevation_deg, 1) << "&#176;)</td></tr>";
  }
  html << "<tr><th>clock</th><td>" << Escape(info.clock_name) << "</td></tr><tr><th>recorded</th><td>"
       << Escape(FormatIso8601(info.created_utc)) << " by " << Escape(info.software_version) << "</td></tr></table>\n";
}

// One row of the overview: the pipeline's headline figures and warnings, linked to its section,
// with its key images (click the relit one to blink it against the source).
void WriteOverviewRow(std::ostringstream& html, const PipelineReport& p, const fs::path& out_dir) {
  html << "<tr><td><a href=\"#pipeline-" << Escape(p.name) << "\">" << Escape(p.name)
       << "</a></td><td class=\"result\">";
  if (p.summary.is_null()) {
    html << "<span class=\"skip\">not run: " << Escape(p.error) << "</span></td><td></td></tr>\n";
    return;
  }
  html << Escape(p.summary.value("headline", std::string("done")));
  for (const nlohmann::json& d : p.summary["decisions"]) {
    if (d["action"] == "warn")
      html << "<br><span class=\"error\">" << Escape(d["reason"].get<std::string>()) << "</span>";
  }
  html << "</td><td class=\"images\">";
  const auto images = KeyImages(p);
  const auto source = std::find_if(images.begin(), images.end(), [](const auto& i) { return i.second == "source"; });
  for (const auto& [path, caption] : images) {
    const std::string src = Escape(fs::relative(path, out_dir).string());
    html << "<figure><img src=\"" << src << "\" alt=\"" << Escape(p.name + " " + caption) << "\"";
    if (caption == "relit" && source != images.end()) {
      html << " class=\"blink\" data-a=\"" << src << "\" data-b=\""
           << Escape(fs::relative(source->first, out_dir).string()) << "\" title=\"click: relit / source\"";
    }
    html << "><figcaption>" << Escape(caption) << "</figcaption></figure>";
  }
  html << "</td></tr>\n";
}

void WriteOverview(std::ostringstream& html, const std::vector<PipelineReport>& pipelines, const fs::path& out_dir) {
  // The overview: each pipeline's headline figures and warnings, linked to its section, with its
  // key images (click the relit one to blink it against the source).
  html << "<h2>Results</h2>\n<table id=\"results\"><tr><th>pipeline</th><th>result</th><th>images</th></tr>\n";
  for (const PipelineReport& p : pipelines) WriteOverviewRow(html, p, out_dir);
  html << "</table>\n";
}

void WriteDevicesAndTimeline(std::ostringstream& html, const capture::SessionReader& session,
                             const std::vector<capture::FrameRecord>& frames,
                             const std::vector<capture::BracketRecord>& brackets,
                             const std::vector<capture::EventRecord>& events) {
  // Devices and frame counts.
  html << "<h2>Devices and frames</h2>\n<table id=\"devices\"><tr><th>device</th><th>model</th><th>frames</th>"
          "<th>brackets (complete / partial)</th></tr>\n";
  for (const drivers::DeviceInfo& d : session.Devices()) {
    const std::string id = d.FullId();
    const auto count = std::count_if(frames.begin(), frames.end(), [&](const auto& f) { return f.device_id == id; });
    int complete = 0, partial = 0;
    for (const capture::BracketRecord& b : brackets) {
      if (b.device_id != id) continue;
      complete += b.status == "complete";
      partial += b.status == "partial";
    }
    html << "<tr><td>" << Escape(id) << "</td><td>" << Escape(d.model) << "</td><td>" << count << "</td><td>"
         << complete << " / " << partial << "</td></tr>\n";
  }
  html << "</table>\n<h2>Timeline</h2>\n" << TimelineSvg(frames, events);
}

void WriteEvents(std::ostringstream& html, const std::vector<capture::EventRecord>& events) {
  html << "<h2>Events</h2>\n";
  if (events.empty()) {
    html << "<p>No faults, retries or other events.</p>\n";
  } else {
    html << "<table id=\"events\"><tr><th>UTC</th><th>device</th><th>type</th><th>message</th></tr>\n";
    for (std::size_t i = 0; i < events.size() && i < 200; ++i) {
      const capture::EventRecord& e = events[i];
      html << "<tr><td>" << Escape(FormatIso8601(e.utc)) << "</td><td>" << Escape(e.device_id) << "</td><td>"
           << Escape(e.type) << "</td><td>" << Escape(e.message) << "</td></tr>\n";
    }
    html << "</table>\n";
    if (events.size() > 200) html << "<p>" << events.size() - 200 << " more events in the session database.</p>\n";
  }
}

void WriteCalibration(std::ostringstream& html, const capture::CalibrationRecord& c, const fs::path& assets) {
  html << "<h3 id=\"calibration-" << c.id << "\">calibration " << c.id << ": " << Escape(c.kind) << " of "
       << Escape(c.device_id) << "</h3>\n<p>";
  if (!c.source_frame_ids.empty()) {
    html << "from frames";
    for (const std::int64_t id : c.source_frame_ids) html << " " << id;
    html << ", ";
  }
  html << "recorded " << Escape(FormatIso8601(c.created_utc)) << "</p>\n";
  if (c.kind == "rgbd_geometry") {
    // An RGB-D sensor's intrinsics and registration, stored by the session writer: not a profile.
    try {
      drivers::RgbdFrame geometry;
      capture::ApplyRgbdGeometryJson(c.json, &geometry);
      const PinholeIntrinsics& k = geometry.color_intrinsics;
      html << "<p>colour " << k.width << "x" << k.height << ", fx " << Fixed(k.fx, 1) << " px; depth "
           << (geometry.registered_to_color ? "registered to colour" : "not registered to colour") << "</p>\n";
    } catch (const Error& e) {
      html << "<p class=\"error\">cannot be read: " << Escape(e.what()) << "</p>\n";
    }
    return;
  }
  if (c.kind != "profile" && c.kind != "response") {
    html << "<p>a calibration of kind " << Escape(c.kind) << " (not shown here)</p>\n";
    return;
  }
  try {
    const calibration::CalibrationProfile profile = calibration::ProfileFromJson(c.json, "calibration");
    if (!profile.camera.empty()) html << "<p>" << Escape(profile.camera) << "</p>\n";
    if (c.kind == "profile") {
      html << "<p>chart fit: " << profile.fit.patches_used << " patches, mean &#916;E2000 "
           << Fixed(profile.fit.mean_delta_e, 3) << ", max " << Fixed(profile.fit.max_delta_e, 3) << ", condition "
           << Fixed(profile.fit.condition, 2) << (profile.fit.low_confidence ? " (low confidence)" : "")
           << "</p>\n<table><tr><th colspan=\"3\">colour matrix</th></tr>";
      for (int r = 0; r < 3; ++r) {
        html << "<tr>";
        for (int k = 0; k < 3; ++k) html << "<td>" << Fixed(profile.ccm(r, k), 4) << "</td>";
        html << "</tr>";
      }
      html << "</table>\n";
      if (profile.fit.patch_delta_e.size() == 24) {
        // The chart as it lies (4 rows of 6, reading order): each patch's Delta E 2000 after the
        // fit; green below 2 (hard to see), orange below 5, red from 5; "-" not used.
        html << "<table class=\"patches\"><tr><th colspan=\"6\">&#916;E2000 per patch</th></tr>";
        for (int r = 0; r < 4; ++r) {
          html << "<tr>";
          for (int k = 0; k < 6; ++k) {
            const double de = profile.fit.patch_delta_e[static_cast<std::size_t>(r * 6 + k)];
            const char* colour = !std::isfinite(de) ? "#eee" : de < 2.0 ? "#cfc" : de < 5.0 ? "#fd9" : "#f99";
            html << "<td style=\"background:" << colour << "\">" << (std::isfinite(de) ? Fixed(de, 2) : "-") << "</td>";
          }
          html << "</tr>";
        }
        html << "</table>\n";
      }
    }
    if (profile.response && !profile.response->sensor_linear) {
      const std::string name = "calibration-" + std::to_string(c.id) + "-response.png";
      calibration::SaveImage(calibration::PlotResponse(*profile.response), (assets / name).string());
      html << "<figure><img src=\"report/" << name << "\" alt=\"inverse response\"><figcaption>inverse response, "
           << profile.response->levels << " levels</figcaption></figure>\n";
    }
  } catch (const Error& e) {
    html << "<p class=\"error\">cannot be read: " << Escape(e.what()) << "</p>\n";
  }
}

void WriteCalibrations(std::ostringstream& html, const std::vector<capture::CalibrationRecord>& calibrations,
                       const fs::path& assets) {
  html << "<h2>Calibrations</h2>\n";
  if (calibrations.empty()) {
    html << "<p>None recorded: camera-encoded frames are linearised with a response recovered from each bracket, "
            "and no colour correction is applied (<code>relume calibrate chart --session</code> records one).</p>\n";
  }
  for (const capture::CalibrationRecord& c : calibrations) WriteCalibration(html, c, assets);
}

void WriteDecisions(std::ostringstream& html, const PipelineReport& p) {
  // Decisions collapsed, counted per action.
  std::map<std::string, int> actions;
  for (const nlohmann::json& d : p.summary["decisions"]) ++actions[d.value("action", "")];
  html << "<details class=\"decisions\"><summary>" << p.summary["decisions"].size() << " decisions:";
  for (const auto& [action, count] : actions) html << " " << count << " " << Escape(action);
  html << "</summary><table class=\"decisions\"><tr><th>stage</th><th>action</th><th>reason</th></tr>\n";
  for (const nlohmann::json& d : p.summary["decisions"]) {
    const std::string action = d.value("action", "");
    html << "<tr><td>" << Escape(d.value("stage", "")) << "</td><td class=\"" << Escape(action) << "\">"
         << Escape(action) << "</td><td>" << Escape(d.value("reason", "")) << "</td></tr>\n";
  }
  html << "</table></details>\n";
}

void WriteFigures(std::ostringstream& html, const PipelineReport& p) {
  // Key figures, labelled, with units (the pipeline's own selection of its metrics).
  for (const PipelineEntry& entry : Pipelines()) {
    if (entry.name != p.name || !entry.figures) continue;
    std::vector<Figure> key_figures;
    try {
      key_figures = entry.figures(p.summary["metrics"]);
    } catch (const IoError& e) {  // a summary.json another version of relume wrote
      html << "<p class=\"warn\">key figures not shown: " << Escape(e.what()) << "</p>\n";
      break;
    }
    if (key_figures.empty()) break;
    html << "<table class=\"key-figures\"><tr><th>figure</th><th>value</th><th>unit</th></tr>\n";
    for (const Figure& kf : key_figures) {
      html << "<tr><td>" << Escape(kf.label) << "</td><td>" << Escape(kf.value) << "</td><td>" << Escape(kf.unit)
           << "</td></tr>\n";
    }
    html << "</table>\n";
  }
  std::vector<std::pair<std::string, std::string>> figures;
  if (p.summary.contains("metrics")) Flatten(p.summary["metrics"], "", figures);
  if (!figures.empty()) {
    html << "<details><summary>all figures (" << figures.size()
         << ", as summary.json names them)</summary><table class=\"metrics\">";
    for (const auto& [key, value] : figures) {
      html << "<tr><td><code>" << Escape(key) << "</code></td><td>" << Escape(value) << "</td></tr>";
    }
    html << "</table></details>\n";
  }
}

void WriteImages(std::ostringstream& html, const PipelineReport& p, const fs::path& out_dir) {
  // The light over time (SH): up to 12 of the fits' lat-long maps, evenly spaced.
  std::vector<std::pair<fs::path, std::string>> lights;
  for (const nlohmann::json& o : p.summary["outputs"]) {
    const std::string what = o.value("what", "");
    const fs::path output = p.out_dir / o.value("path", "");
    if (output.filename() == "latlong.png" && fs::exists(output)) lights.emplace_back(output, what);
  }
  if (lights.size() > 1) {
    html << "<h3>Light over time</h3>\n<div class=\"lights\">";
    const std::size_t shown_count = std::min<std::size_t>(12, lights.size());
    for (std::size_t i = 0; i < shown_count; ++i) {
      const auto& [path, what] = lights[i * (lights.size() - 1) / std::max<std::size_t>(1, shown_count - 1)];
      html << "<figure><img class=\"light\" src=\"" << Escape(fs::relative(path, out_dir).string()) << "\" alt=\""
           << Escape(what) << "\"><figcaption>" << Escape(what) << "</figcaption></figure>";
    }
    html << "</div>\n";
  }
  // Every output image; more than a dozen (an RGB-D stream's frames) collapsed.
  std::set<fs::path> shown;
  std::ostringstream gallery;
  for (const nlohmann::json& o : p.summary["outputs"]) {
    const fs::path output = p.out_dir / o.value("path", "");
    const std::optional<fs::path> image = ShownImage(output);
    if (!image || !fs::exists(*image) || !shown.insert(*image).second) continue;
    gallery << "<figure><img src=\"" << Escape(fs::relative(*image, out_dir).string()) << "\" alt=\""
            << Escape(o.value("what", "")) << "\"><figcaption>" << Escape(o.value("what", ""))
            << "</figcaption></figure>\n";
  }
  if (shown.size() > 12) {
    html << "<details><summary>all " << shown.size() << " images</summary>\n" << gallery.str() << "</details>\n";
  } else {
    html << gallery.str();
  }
}

void WritePipelineSection(std::ostringstream& html, const PipelineReport& p, const fs::path& out_dir) {
  html << "<h2 id=\"pipeline-" << Escape(p.name) << "\">Pipeline: " << Escape(p.name) << "</h2>\n";
  if (p.summary.is_null()) {
    html << "<p class=\"skip\">not run: " << Escape(p.error) << "</p>\n";
    return;
  }
  html << "<p>" << Fixed(p.summary.value("seconds", 0.0), 2) << " s; output in <code>"
       << Escape(fs::relative(p.out_dir, out_dir).string()) << "</code></p>\n";
  WriteDecisions(html, p);
  WriteFigures(html, p);
  WriteImages(html, p, out_dir);
}

void WriteScript(std::ostringstream& html) {
  html << "<script>\ndocument.querySelectorAll('img.blink').forEach(function (img) {\n"
          "  img.addEventListener('click', function () {\n"
          "    var a = img.getAttribute('data-a'), b = img.getAttribute('data-b');\n"
          "    img.setAttribute('src', img.getAttribute('src') === a ? b : a);\n"
          "  });\n"
          "});\nwindow.addEventListener('load', function () {\n"
          "  var ok = 0, broken = 0;\n"
          "  document.querySelectorAll('img').forEach(function (img) {\n"
          "    if (img.complete && img.naturalWidth > 0) { ok++; } else { broken++; }\n"
          "  });\n"
          "  document.body.setAttribute('data-images-loaded', ok);\n"
          "  document.body.setAttribute('data-images-broken', broken);\n"
          "  document.body.setAttribute('data-figures', document.querySelectorAll('svg.figure').length);\n"
          "  document.body.setAttribute('data-script-errors', window.relumeErrors);\n"
          "  var results = document.getElementById('results');\n"
          "  if (results) document.body.setAttribute('data-overview-bottom',\n"
          "      Math.round(results.getBoundingClientRect().bottom + window.scrollY));\n"
          "});\n</script>\n</body>\n</html>\n";
}

}  // namespace

fs::path WriteReport(const capture::SessionReader& session, const fs::path& out_dir,
                     const std::vector<PipelineReport>& pipelines) {
  const fs::path assets = out_dir / "report";
  capture::CreateDirectoryDurably(assets);
  const capture::SessionInfo& info = session.info();
  const std::vector<capture::FrameRecord> frames = session.Frames();
  const std::vector<capture::BracketRecord> brackets = session.Brackets();
  const std::vector<capture::EventRecord> events = session.Events();
  std::ostringstream html;
  WriteHead(html, info);
  WriteSessionTable(html, session, info, frames);
  WriteOverview(html, pipelines, out_dir);
  WriteDevicesAndTimeline(html, session, frames, brackets, events);
  WriteEvents(html, events);
  WriteCalibrations(html, session.Calibrations(), assets);
  for (const PipelineReport& p : pipelines) WritePipelineSection(html, p, out_dir);
  WriteScript(html);
  const std::string text = html.str();
  const fs::path page = out_dir / "report.html";
  capture::WriteFileDurably(page, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  return page;
}

}  // namespace relume::pipeline
