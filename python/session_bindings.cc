// relume.Session: a recorded session read through capture::SessionReader: its site, devices,
// frames with their metadata (as dicts), brackets, calibrations, and the frames' pixels as numpy
// arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/scene_model.h"
#include "pipeline/irm_scene.h"
#include "pipeline/pipeline.h"
#include "pipeline/radiance.h"
#include "python/bindings.h"
#include "python/convert.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

std::string Iso(UtcTime time) {
  return FormatIso8601(time, std::chrono::seconds{0}, 3);
}

double UnixSeconds(UtcTime time) {
  return std::chrono::duration<double>(time.time_since_epoch()).count();
}

py::object Optional(double value) {
  return std::isnan(value) ? py::object(py::none()) : py::object(py::float_(value));
}

py::dict FrameToDict(const capture::FrameRecord& f) {
  py::dict d;
  d["id"] = f.id;
  d["device"] = f.device_id;
  d["stream"] = f.stream;
  d["bracket_id"] = f.bracket_id ? py::object(py::int_(*f.bracket_id)) : py::object(py::none());
  d["bracket_index"] = f.bracket_index;
  d["utc"] = Iso(f.utc);
  d["unix_seconds"] = UnixSeconds(f.utc);
  d["sequence"] = f.sequence;
  d["exposure_time_s"] = Optional(f.exposure.exposure_time_s);
  d["ev_compensation"] = f.exposure.ev_compensation;
  d["aperture_f"] = Optional(f.exposure.aperture_f);
  d["iso"] = Optional(f.exposure.iso);
  d["gain_db"] = Optional(f.exposure.gain_db);
  d["file_path"] = f.file_path;
  d["sha256"] = f.sha256;
  d["file_format"] = f.file_format;
  d["layout"] = ToString(f.layout);
  d["encoding"] = ToString(f.encoding);
  d["bits_per_sample"] = f.bits_per_sample;
  d["black_level"] = f.black_level;
  d["white_level"] = f.white_level;
  d["width"] = f.width;
  d["height"] = f.height;
  d["sun_elevation_deg"] = f.sun_elevation_deg;
  d["sun_azimuth_deg"] = f.sun_azimuth_deg;
  d["sun_algorithm"] = f.sun_algorithm;
  d["sensor_temperature_c"] =
      f.sensor_temperature_c ? py::object(py::float_(*f.sensor_temperature_c)) : py::object(py::none());
  return d;
}

// The session and its frames, read once at open (frames are looked up by id).
class Session {
 public:
  explicit Session(const std::filesystem::path& dir)
      : reader_(std::make_unique<capture::SessionReader>(dir)), frames_(reader_->Frames()) {}

  std::string path() const { return reader_->dir().string(); }
  py::dict Info() const {
    const capture::SessionInfo& info = reader_->info();
    py::dict d;
    d["name"] = info.name;
    d["site"] = py::dict("lat_deg"_a = info.site.latitude_deg(), "lon_deg"_a = info.site.longitude_deg(),
                         "height_m"_a = info.site.height_m);
    d["software_version"] = info.software_version;
    d["clock"] = info.clock_name;
    d["created_utc"] = Iso(info.created_utc);
    d["rig_config"] = info.rig_config;
    return d;
  }
  py::list Frames() const {
    py::list out;
    for (const capture::FrameRecord& f : frames_) out.append(FrameToDict(f));
    return out;
  }
  py::list Devices() const {
    py::list out;
    for (const drivers::DeviceInfo& d : reader_->Devices()) {
      out.append(py::dict("id"_a = d.FullId(), "backend"_a = d.backend, "model"_a = d.model, "serial"_a = d.serial,
                          "address"_a = d.address, "details"_a = d.details));
    }
    return out;
  }
  py::list Brackets() const {
    py::list out;
    for (const capture::BracketRecord& b : reader_->Brackets()) {
      out.append(py::dict("id"_a = b.id, "device"_a = b.device_id, "started_utc"_a = Iso(b.started_utc),
                          "planned_count"_a = b.planned_count, "status"_a = b.status, "reason"_a = b.reason));
    }
    return out;
  }
  py::list Calibrations() const {
    py::list out;
    for (const capture::CalibrationRecord& c : reader_->Calibrations()) {
      out.append(py::dict("id"_a = c.id, "created_utc"_a = Iso(c.created_utc), "kind"_a = c.kind,
                          "device"_a = c.device_id, "data"_a = JsonToPython(c.json),
                          "source_frame_ids"_a = c.source_frame_ids));
    }
    return out;
  }
  py::list Events() const {
    py::list out;
    for (const capture::EventRecord& e : reader_->Events()) {
      out.append(py::dict("id"_a = e.id, "utc"_a = Iso(e.utc), "device"_a = e.device_id, "type"_a = e.type,
                          "message"_a = e.message));
    }
    return out;
  }
  py::array LoadImage(std::int64_t frame_id, bool verify_checksum) const {
    const capture::FrameRecord& frame = Find(frame_id);
    cv::Mat pixels;
    {
      py::gil_scoped_release release;
      pixels = reader_->LoadImage(frame, verify_checksum).pixels;
    }
    return MatToArray(std::move(pixels));
  }
  py::array LoadDepth(std::int64_t frame_id, bool verify_checksum) const {
    const capture::FrameRecord& frame = Find(frame_id);
    if (frame.stream != "depth") {
      throw InvalidArgumentError("load_depth: frame " + std::to_string(frame_id) + " is a " + frame.stream +
                                 " frame, not a depth frame (load_image reads it)");
    }
    cv::Mat depth;
    {
      py::gil_scoped_release release;
      depth = reader_->LoadDepth(frame, verify_checksum);
    }
    return MatToArray(std::move(depth));
  }

 private:
  const capture::FrameRecord& Find(std::int64_t frame_id) const {
    for (const capture::FrameRecord& f : frames_) {
      if (f.id == frame_id) return f;
    }
    throw InvalidArgumentError("session " + path() + " has no frame " + std::to_string(frame_id) + " (it has " +
                               std::to_string(frames_.size()) + " frames; Session.frames lists them)");
  }

  // The session's scene model (its latest scene_model calibration row, core/scene_model.h): the
  // cameras and geometry the pipelines use. Read at first use; InvalidArgumentError without one.
  const SceneModel& Model(const char* what) const {
    if (!model_) {
      const std::vector<capture::CalibrationRecord> rows = reader_->Calibrations();
      const capture::CalibrationRecord* row = capture::LatestSceneModelRow(rows);
      if (row == nullptr) {
        throw InvalidArgumentError(std::string(what) + ": session " + path() +
                                   " has no scene model: " + pipeline::SceneModelAdvice(reader_->dir()));
      }
      model_ = capture::SceneModelFromJson(row->json, path() + ": calibration row " + std::to_string(row->id));
    }
    return *model_;
  }

 public:
  py::dict Camera(const std::string& device_id) const {
    const SceneModel& model = Model("camera");
    const SceneModelCamera* camera = model.FindCamera(device_id);
    if (camera == nullptr) {
      std::string have;
      for (const SceneModelCamera& c : model.cameras) have += (have.empty() ? "" : ", ") + c.device_id;
      throw InvalidArgumentError("camera: the session's scene model has no camera '" + device_id + "' (it has " +
                                 (have.empty() ? "none" : have) + ")");
    }
    py::dict d = CameraToPython(camera->camera);
    d["device_id"] = camera->device_id;
    d["distortion"] = camera->distortion;
    d["source"] = camera->source;
    d["reprojection_error_px"] = camera->reprojection_error_px < 0.0
                                     ? py::object(py::none())
                                     : py::object(py::float_(camera->reprojection_error_px));
    return d;
  }
  py::dict SceneMesh(double spacing_m, int sphere_segments) const {
    pipeline::IrmMeshOptions options;
    options.spacing_m = spacing_m;
    options.sphere_segments = sphere_segments;
    ThrowIfInvalid(options, "scene_mesh");
    const SceneModel& model = Model("scene_mesh");
    TriangleMesh mesh;
    {
      py::gil_scoped_release release;
      mesh = pipeline::ProcessingMeshFromModel(model, options);
    }
    return MeshToPython(mesh);
  }

  py::dict LinearRadiance(const py::object& frames, bool use_calibrations, int merge_black_margin,
                          int merge_saturation_margin, int response_samples, double response_lambda,
                          const std::string& response_smoothness) const {
    calibration::HdrMergeOptions merge;
    merge.black_margin = merge_black_margin;
    merge.saturation_margin = merge_saturation_margin;
    ThrowIfInvalid(merge, "linear_radiance");
    calibration::ResponseOptions response_options;
    response_options.sample_count = response_samples;
    response_options.lambda = response_lambda;
    response_options.smoothness = calibration::ResponseSmoothnessFromString(response_smoothness);
    ThrowIfInvalid(response_options, "linear_radiance");
    const std::string selector = py::str(frames).cast<std::string>();
    const auto brackets = pipeline::StillBrackets(*reader_, selector);
    if (brackets.size() != 1) {
      throw InvalidArgumentError("linear_radiance: " + selector + " selects " + std::to_string(brackets.size()) +
                                 " still brackets; select one (bracket:N or a frame id)");
    }
    const std::vector<capture::FrameRecord>& bracket = brackets.front();
    pipeline::DeviceCalibrations calibrations;
    if (use_calibrations) calibrations = pipeline::RecordedCalibrations(*reader_, bracket.front().device_id);
    pipeline::LinearisedBracket linear;
    {
      py::gil_scoped_release release;
      linear = pipeline::LineariseBracket(*reader_, bracket, calibrations.response, calibrations.profile, merge,
                                          response_options);
    }
    py::list ids;
    for (const capture::FrameRecord& f : bracket) ids.append(f.id);
    return py::dict("radiance"_a = MatToArray(std::move(linear.radiance.pixels)),
                    "status"_a = MatToArray(std::move(linear.status)), "response_source"_a = linear.response_source,
                    "frame_ids"_a = ids, "profile_id"_a = calibrations.profile_id,
                    "response_id"_a = calibrations.response_id);
  }

 private:
  std::unique_ptr<capture::SessionReader> reader_;
  std::vector<capture::FrameRecord> frames_;
  mutable std::optional<SceneModel> model_;
};

}  // namespace

void BindSession(py::module_& m) {
  py::class_<Session>(m, "Session", R"doc(A recorded session (`relume capture`), read-only.

    session = relume.Session("out/demo/session")
    for f in session.frames: print(f["id"], f["device"], f["utc"], f["sun_elevation_deg"])
    pixels = session.load_image(session.frames[0]["id"])

Raises relume.IoError (an OSError) when the folder holds no session.)doc")
      .def(py::init<std::filesystem::path>(), "path"_a, "Opens the session folder (read-only).")
      .def_property_readonly("path", &Session::path, "The session folder.")
      .def_property_readonly("info", &Session::Info,
                             "dict: name, site (lat_deg, lon_deg, height_m), software_version, clock, created_utc, "
                             "rig_config (the rig's YAML).")
      .def_property_readonly(
          "frames", &Session::Frames,
          "list of dicts, one per frame in acknowledgement order: id, device, stream ('still', 'color' or 'depth'), "
          "bracket_id, bracket_index, utc (ISO 8601), unix_seconds, exposure_time_s, ev_compensation, aperture_f, "
          "iso, gain_db (None when unknown), file_path, sha256, file_format, layout, encoding, bits_per_sample, "
          "black_level, white_level, width, height, sun_elevation_deg, sun_azimuth_deg, sun_algorithm, "
          "sensor_temperature_c.")
      .def_property_readonly("devices", &Session::Devices,
                             "list of dicts: id, backend, model, serial, address, details.")
      .def_property_readonly("brackets", &Session::Brackets,
                             "list of dicts: id, device, started_utc, planned_count, status, reason.")
      .def_property_readonly("calibrations", &Session::Calibrations,
                             "list of dicts: id, created_utc, kind, device, data (the parsed JSON), source_frame_ids.")
      .def_property_readonly("events", &Session::Events, "list of dicts: id, utc, device, type, message.")
      .def("load_image", &Session::LoadImage, "frame_id"_a, py::kw_only(), "verify_checksum"_a = true,
           R"doc(A still or colour frame's pixels as stored: uint8 or uint16, HxWx3 in RGB order, or HxW
(mono or a raw Bayer mosaic; the frame's layout, black_level and white_level say which).
Raises relume.IoError when the file is missing, its checksum differs or it cannot be decoded.)doc")
      .def("camera", &Session::Camera, "device_id"_a,
           R"doc(A device's camera from the session's scene model (its latest scene_model calibration
row; what the pipelines use): dict {'width', 'height', 'fx', 'fy', 'cx', 'cy' (pixels; pixel
centres at +0.5), 'world_from_camera' (float64 4x4, metres, ENU at the site; camera x right,
y down, z forward), 'device_id', 'distortion' (OpenCV k1, k2, p1, p2[, k3]; empty: none; the
pipelines and irm_relight take pinhole images), 'source', 'reprojection_error_px' (None: not
measured)}. device_id: 'sim:dslr' or 'dslr' (a frame's 'device'). Raises
relume.InvalidArgumentError when the session has no scene model or the model no such camera.)doc")
      .def("scene_mesh", &Session::SceneMesh, py::kw_only(), "spacing_m"_a = pipeline::IrmMeshOptions{}.spacing_m,
           "sphere_segments"_a = pipeline::IrmMeshOptions{}.sphere_segments,
           R"doc(The session's scene model as the IRM pipeline's mesh (pipeline/irm_scene.h ProcessingMeshFromModel).

Every triangle split so that no edge exceeds spacing_m (metres; the irm pipeline's
mesh_spacing_m knob) with its own vertices and flat normal; spheres tessellated with
sphere_segments around the equator. Returns dict {'positions' (N, 3) float32 metres in ENU at
the site, 'triangles' (M, 3) int32, 'normals' (N, 3) float32 unit, 'parts' (N,) int32: the
scene model's object of each vertex}, what irm_relight takes.
Raises relume.InvalidArgumentError when the session has no scene model.)doc")
      .def("linear_radiance", &Session::LinearRadiance, "frames"_a, py::kw_only(), "use_calibrations"_a = true,
           "merge_black_margin"_a = calibration::HdrMergeOptions{}.black_margin,
           "merge_saturation_margin"_a = calibration::HdrMergeOptions{}.saturation_margin,
           "response_samples"_a = calibration::ResponseOptions{}.sample_count,
           "response_lambda"_a = calibration::ResponseOptions{}.lambda,
           "response_smoothness"_a = calibration::ToString(calibration::ResponseOptions{}.smoothness),
           R"doc(One still bracket (or frame) as linear radiance, as the pipelines' radiance stage makes it
(pipeline/radiance.h LineariseBracket): raw frames through their levels (Bayer mosaics
demosaiced), camera-encoded ones through the device's recorded response (else one recovered
from the bracket), merged with the exposures t * ISO / 100, and the device's recorded colour
profile applied. `relume process --pipeline radiance` writes the same pixels.

Args:
    frames: a selector of one bracket: 'bracket:N' or a frame id.
    use_calibrations: use the session's recorded response and profile (False: neither; raw
        frames stay as they are, encoded ones get a response recovered from the bracket).
    merge_black_margin, merge_saturation_margin, response_samples, response_lambda,
        response_smoothness: the radiance knobs of `relume process --set` (codes; pixels;
        smoothness weight; 'log-code' or 'code').

Returns:
    dict: radiance float32 HxWx3 (relative units), status uint8 HxW (0 good, 1 saturated
    everywhere, 2 black everywhere), response_source (how the frames were linearised),
    frame_ids, profile_id and response_id (the calibrations used; 0: none).
)doc")
      .def("load_depth", &Session::LoadDepth, "frame_id"_a, py::kw_only(), "verify_checksum"_a = true,
           "A depth frame as float32 HxW metres, NaN where there was no measurement.");
}

}  // namespace relume::python
