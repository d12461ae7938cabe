// relume.process: runs the processing pipelines on a session through the library call the CLI
// makes (pipeline/process.h ProcessSession), with the CLI's defaults and checks; relume.pipelines
// lists them and their knobs.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "core/error.h"
#include "pipeline/pipeline.h"
#include "pipeline/process.h"
#include "python/bindings.h"
#include "rig/session_truth.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

// A --set value as the CLI would receive it: booleans as true/false, numbers and text as str().
std::string SettingText(const std::string& key, const py::handle& value) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::str>(value) || py::isinstance<py::int_>(value) || py::isinstance<py::float_>(value)) {
    return py::str(value).cast<std::string>();
  }
  throw InvalidArgumentError("settings['" + key + "']: expected a bool, a number or a string, got " +
                             std::string(py::str(value.get_type().attr("__name__"))));
}

std::optional<std::string> OptionalText(const py::object& value) {
  if (value.is_none()) return std::nullopt;
  return py::str(value).cast<std::string>();
}

py::dict Process(const std::filesystem::path& session_dir, const std::string& pipeline,
                 const std::optional<std::filesystem::path>& out_dir, const py::object& source,
                 const py::object& target, const std::optional<std::filesystem::path>& mesh,
                 const py::object& target_light, const std::optional<py::dict>& settings, bool explain, bool force) {
  const bool all = pipeline.empty() || pipeline == "all";
  pipeline::PipelineRequest request;
  request.session_dir = session_dir;
  // The CLI's default output folder: SESSION/processed[/PIPELINE].
  request.out_dir = out_dir ? *out_dir : session_dir / "processed" / (all ? std::string() : pipeline);
  request.pipeline = pipeline;
  request.source = OptionalText(source);
  request.target = OptionalText(target);
  request.mesh = mesh;
  request.target_light = OptionalText(target_light);
  if (settings) {
    for (const auto& [key, value] : *settings) {
      const std::string name = py::str(key).cast<std::string>();
      request.settings[name] = SettingText(name, value);
    }
  }
  request.explain = explain;
  request.reuse = !force;
  request.load_truth = rig::LoadSessionTruth;  // evaluation; null for real sessions
  pipeline::ProcessResult result;
  {
    py::gil_scoped_release release;
    result = pipeline::ProcessSession(request);
  }
  py::dict pipelines;
  for (const pipeline::PipelineReport& r : result.reports) {
    pipelines[py::str(r.name)] =
        py::dict("out_dir"_a = r.out_dir.string(),
                 "summary"_a = r.summary.is_null() ? py::object(py::none()) : JsonToPython(r.summary.dump()),
                 "error"_a = r.error.empty() ? py::object(py::none()) : py::object(py::str(r.error)));
  }
  if (!result.failed.empty()) {
    std::string names;
    for (const std::string& n : result.failed) names += (names.empty() ? "" : ", ") + n;
    throw Error("pipeline(s) " + names + " failed; the others' results are kept in " + request.out_dir.string());
  }
  return py::dict(
      "pipelines"_a = pipelines,
      "report"_a = result.report.empty() ? py::object(py::none()) : py::object(py::str(result.report.string())),
      "out_dir"_a = request.out_dir.string());
}

py::list PipelineList() {
  py::list out;
  for (const pipeline::PipelineEntry& entry : pipeline::Pipelines()) {
    py::list knobs;
    for (const pipeline::KnobInfo& k : entry.knobs) {
      knobs.append(py::dict("name"_a = k.name, "type"_a = k.type, "default"_a = JsonToPython(k.default_value.dump()),
                            "help"_a = k.help, "stages"_a = k.stages));
    }
    out.append(py::dict("name"_a = entry.name, "description"_a = entry.description, "knobs"_a = knobs));
  }
  return out;
}

}  // namespace

void BindProcess(py::module_& m) {
  m.def("process", &Process, "session_dir"_a, "pipeline"_a = "all", py::kw_only(), "out_dir"_a = py::none(),
        "source"_a = py::none(), "target"_a = py::none(), "mesh"_a = py::none(), "target_light"_a = py::none(),
        "settings"_a = py::none(), "explain"_a = false, "force"_a = false,
        R"doc(Reprocesses a session as `relume process` does, reusing unchanged stages.

Args:
    session_dir: the session folder (from `relume capture`).
    pipeline: a pipeline name (relume.pipelines() lists them) or 'all'.
    out_dir: output folder; default SESSION/processed (all) or SESSION/processed/PIPELINE,
        as the CLI.
    source, target: frame selectors: a frame id, 'bracket:N', 'DEVICE:STREAM' or 'all'
        (--source, --target).
    mesh: scene geometry when the session did not record it (--mesh).
    target_light: destination lighting: a frame selector, an SH .json or an environment map.
    settings: the pipeline's knobs, {key: value} (--set key=value); a key no pipeline has is
        refused with relume's message (relume.InvalidArgumentError) before anything runs.
    explain: decide and record the plan only (--explain).
    force: recompute every stage (--force).

Returns:
    dict: 'pipelines' maps each pipeline that was considered to {'out_dir', 'summary' (its
    summary.json as a dict, None when it did not run), 'error' (why not, or None)}; 'report'
    is report.html's path (None with explain); 'out_dir' the output folder.

Raises:
    relume.InvalidArgumentError for a bad setting, selector or a pipeline that cannot run on
    the session (when one pipeline was asked for); relume.Error when a pipeline failed while
    running all of them (the others' results stay on disk).
)doc");
  m.def("pipelines", &PipelineList,
        "The pipelines of this build: a list of dicts with name, description and knobs (name, type, default, help, "
        "stages), as `relume process --list --pipeline NAME` prints them.");
}

}  // namespace relume::python
