#include "batch/index.h"

#include <cstdio>
#include <map>
#include <span>

#include "capture/durable_file.h"

namespace relume::batch {
namespace fs = std::filesystem;

int BatchSummary::Count(TaskState state) const {
  int n = 0;
  for (const TaskOutcome& t : tasks) n += t.state == state ? 1 : 0;
  return n;
}

std::vector<int> BatchSummary::Unfinished() const {
  std::vector<int> indices;
  for (const TaskOutcome& t : tasks) {
    if (t.state == TaskState::kFailed || t.state == TaskState::kNotRun) indices.push_back(t.index);
  }
  return indices;
}

std::string BatchSummary::BriefReport() const {
  std::string text = std::to_string(tasks.size()) + " session(s): " + std::to_string(Count(TaskState::kDone)) + " done";
  for (const TaskState s : {TaskState::kFailed, TaskState::kRunning, TaskState::kQueued, TaskState::kNotRun}) {
    if (Count(s) > 0) text += ", " + std::to_string(Count(s)) + " " + TaskStateName(s);
  }
  const std::vector<int> unfinished = Unfinished();
  if (!unfinished.empty()) {
    std::string list;
    for (const int i : unfinished) {
      if (!list.empty()) list += ',';
      list += std::to_string(i);
    }
    text += unfinished.size() > 1 ? " (tasks " : " (task ";
    text += list;
    text += ')';
  }
  if (!index_html.empty()) text += "; index: " + index_html.string();
  return text;
}

namespace {

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// Appends ",<field>" (one call per cell; not `"," + text`, on which GCC 12 -O3 warns falsely).
void Cell(std::string& out, const std::string& text) {
  out += ',';
  out += CsvField(text);
}

std::string Html(const std::string& text) {
  std::string out;
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

// A relative path as an href: each character outside the unreserved set percent-encoded.
std::string Href(const std::string& path) {
  std::string out;
  for (const unsigned char c : path) {
    if (std::isalnum(c) != 0 || c == '/' || c == '.' || c == '-' || c == '_' || c == '~') {
      out += static_cast<char>(c);
    } else {
      char hex[4];
      std::snprintf(hex, sizeof(hex), "%%%02X", c);
      out += hex;
    }
  }
  return out;
}

// The session folder with its parent ("day3/session"): sessions are often all called "session".
std::string ShortName(const std::string& session) {
  const fs::path path(session);
  return (path.parent_path().filename() / path.filename()).string();
}

std::string Seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", s);
  return text;
}

// Each (pipeline, figure label, unit) in order of first appearance: the CSV's figure columns.
struct Column {
  std::string pipeline, label, unit;
  std::string Name() const { return pipeline + ": " + label + (unit.empty() ? "" : " [" + unit + "]"); }
};

std::vector<Column> FigureColumns(const BatchSummary& summary) {
  std::vector<Column> columns;
  std::map<std::string, bool> seen;
  for (const TaskOutcome& t : summary.tasks) {
    for (const PipelineOutcome& p : t.pipelines) {
      for (const FigureValue& f : p.figures) {
        const Column c{p.name, f.label, f.unit};
        if (!seen.emplace(c.Name(), true).second) continue;
        columns.push_back(c);
      }
    }
  }
  return columns;
}

std::vector<std::string> PipelineNames(const BatchSummary& summary) {
  std::vector<std::string> names;
  for (const TaskOutcome& t : summary.tasks) {
    for (const PipelineOutcome& p : t.pipelines) {
      if (std::find(names.begin(), names.end(), p.name) == names.end()) names.push_back(p.name);
    }
  }
  return names;
}

const PipelineOutcome* FindPipeline(const TaskOutcome& t, const std::string& name) {
  for (const PipelineOutcome& p : t.pipelines) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::string PipelineText(const PipelineOutcome* p) {
  if (p == nullptr) return "";
  if (!p->error.empty()) return p->error.rfind("failed: ", 0) == 0 ? p->error : "not run: " + p->error;
  return p->headline.empty() ? "done" : p->headline;
}

void WriteText(const fs::path& file, const std::string& text) {
  capture::WriteFileDurably(file, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

}  // namespace

std::string IndexCsv(const BatchSummary& summary) {
  const std::vector<Column> columns = FigureColumns(summary);
  const std::vector<std::string> pipelines = PipelineNames(summary);
  std::string out = "task,session,state,seconds,report,log,message";
  for (const std::string& name : pipelines) Cell(out, name + ": headline");
  for (const Column& c : columns) Cell(out, c.Name());
  out += '\n';
  for (const TaskOutcome& t : summary.tasks) {
    out += std::to_string(t.index);
    Cell(out, t.session);
    Cell(out, TaskStateName(t.state));
    Cell(out, t.state == TaskState::kDone || t.state == TaskState::kFailed ? Seconds(t.seconds) : "");
    Cell(out, t.report);
    Cell(out, t.log);
    Cell(out, t.message);
    for (const std::string& name : pipelines) Cell(out, PipelineText(FindPipeline(t, name)));
    for (const Column& c : columns) {
      std::string value;
      if (const PipelineOutcome* p = FindPipeline(t, c.pipeline)) {
        for (const FigureValue& f : p->figures) {
          if (f.label == c.label && f.unit == c.unit) value = f.value;
        }
      }
      Cell(out, value);
    }
    out += '\n';
  }
  return out;
}

std::string IndexHtml(const BatchSummary& summary) {
  const std::vector<std::string> pipelines = PipelineNames(summary);
  double task_seconds = 0.0;
  for (const TaskOutcome& t : summary.tasks) task_seconds += t.seconds;
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>relume batch: " +
                  Html(summary.out_dir.filename().string()) +
                  "</title>\n<style>body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}"
                  "td,th{border:1px solid #ccc;padding:.25em .5em;text-align:left;vertical-align:top}"
                  ".done{color:#060}.failed{color:#b00;font-weight:bold}.running,.queued,.not-run{color:#a60}"
                  "code{background:#f4f4f4}</style></head>\n<body data-tasks=\"" +
                  std::to_string(summary.tasks.size()) + "\" data-done=\"" +
                  std::to_string(summary.Count(TaskState::kDone)) + "\" data-failed=\"" +
                  std::to_string(summary.Count(TaskState::kFailed)) + "\">\n<h1>relume batch</h1>\n";
  h += "<p id=\"headline\">" + Html(std::to_string(summary.tasks.size())) + " sessions: <b>" +
       std::to_string(summary.Count(TaskState::kDone)) + " done</b>, <b>" +
       std::to_string(summary.Count(TaskState::kFailed)) + " failed</b>";
  for (const TaskState s : {TaskState::kRunning, TaskState::kQueued, TaskState::kNotRun}) {
    if (summary.Count(s) > 0) h += ", " + std::to_string(summary.Count(s)) + " " + TaskStateName(s);
  }
  h += ". Backend " + Html(summary.backend) + (summary.job_id.empty() ? "" : ", Slurm job " + Html(summary.job_id)) +
       "; task time " + Seconds(task_seconds) + " s" +
       (summary.wall_seconds > 0 ? ", wall time of the last run " + Seconds(summary.wall_seconds) + " s" : "") +
       ". <a href=\"index.csv\">index.csv</a></p>\n";

  const std::vector<int> unfinished = summary.Unfinished();
  if (!unfinished.empty()) {
    h += "<h2>Failed or not run</h2>\n<table id=\"failed\"><tr><th>task</th><th>session</th><th>why</th><th>log</th>"
         "</tr>\n";
    for (const TaskOutcome& t : summary.tasks) {
      if (t.state != TaskState::kFailed && t.state != TaskState::kNotRun) continue;
      h += "<tr><td>" + std::to_string(t.index) + "</td><td>" + Html(t.session) + "</td><td>" +
           Html(t.message.empty() ? TaskStateName(t.state) : t.message) + "</td><td>" +
           (t.log.empty() ? "" : "<a href=\"" + Href(t.log) + "\">" + Html(t.log) + "</a>") + "</td></tr>\n";
    }
    h += "</table>\n<p>Rerun them alone: <code>relume batch --out " + Html(summary.out_dir.string()) +
         " --only-failed</code> (with <code>--slurm</code> or <code>--local N</code>).</p>\n";
  }

  h += "<h2>Sessions</h2>\n<table id=\"sessions\"><tr><th>task</th><th>session</th><th>state</th><th>s</th>";
  for (const std::string& name : pipelines) h += "<th>" + Html(name) + "</th>";
  h += "<th>report</th></tr>\n";
  for (const TaskOutcome& t : summary.tasks) {
    std::string css = TaskStateName(t.state);
    std::replace(css.begin(), css.end(), ' ', '-');
    h += "<tr><td>" + std::to_string(t.index) + "</td><td title=\"" + Html(t.session) + "\">" +
         Html(ShortName(t.session)) + "</td><td class=\"" + css + "\">" + TaskStateName(t.state) + "</td><td>" +
         (t.seconds > 0 ? Seconds(t.seconds) : "") + "</td>";
    for (const std::string& name : pipelines) h += "<td>" + Html(PipelineText(FindPipeline(t, name))) + "</td>";
    h += "<td>" + (t.report.empty() ? std::string() : "<a href=\"" + Href(t.report) + "\">report</a>") + "</td></tr>\n";
  }
  h += "</table>\n</body></html>\n";
  return h;
}

void WriteIndex(BatchSummary& summary) {
  summary.index_csv = summary.out_dir / "index.csv";
  summary.index_html = summary.out_dir / "index.html";
  WriteText(summary.index_csv, IndexCsv(summary));
  WriteText(summary.index_html, IndexHtml(summary));
}

}  // namespace relume::batch
