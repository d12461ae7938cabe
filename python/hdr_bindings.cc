// relume.recover_response and relume.merge_hdr on numpy brackets (calibration/response.h,
// calibration/hdr_merge.h). Frames are uint8 HxWx3 (RGB) or HxW arrays encoded by the camera's
// response; C-contiguous frames are read in place, without a copy.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "calibration/hdr_merge.h"
#include "calibration/image_file.h"
#include "calibration/response.h"
#include "core/error.h"
#include "python/bindings.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

// How the frames' samples are stored: None = the dtype's default (uint8: camera-encoded, 8 bits,
// 0..255; uint16: sensor-linear counts, 16 bits, 0..65535).
struct SampleLevels {
  std::optional<int> black_level;
  std::optional<int> white_level;
  std::optional<int> bits_per_sample;
};

// The bracket as CameraImages over the arrays' buffers; `keep` holds the arrays. uint8 frames are
// camera-encoded, uint16 frames sensor-linear (raw counts); all frames have the first's dtype.
std::vector<CameraImage> FramesFromArrays(const py::sequence& frames, const SampleLevels& levels,
                                          std::vector<py::array>* keep) {
  std::vector<CameraImage> images;
  bool sixteen_bit = false;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::string what = "frames[" + std::to_string(i) + "]";
    py::array array = py::array::ensure(frames[i]);
    if (!array) throw InvalidArgumentError(what + ": not an array");
    if (i == 0) sixteen_bit = array.dtype().equal(py::dtype::of<std::uint16_t>());
    if (sixteen_bit) {
      keep->push_back(ContiguousArray<std::uint16_t>(array, what));
    } else {
      keep->push_back(ContiguousArray<std::uint8_t>(array, what));
    }
    CameraImage image;
    image.pixels = MatView(keep->back(), what);
    if (image.pixels.channels() != 1 && image.pixels.channels() != 3) {
      throw InvalidArgumentError(what + ": expected HxW or HxWx3 (RGB), got " +
                                 std::to_string(image.pixels.channels()) + " channels");
    }
    image.layout = image.pixels.channels() == 1 ? ColorLayout::kMono : ColorLayout::kRgb;
    image.encoding = sixteen_bit ? SampleEncoding::kSensorLinear : SampleEncoding::kCameraResponse;
    image.bits_per_sample = levels.bits_per_sample.value_or(sixteen_bit ? 16 : 8);
    image.black_level = levels.black_level.value_or(0);
    image.white_level = levels.white_level.value_or(
        image.bits_per_sample >= 8 && image.bits_per_sample <= 16 ? (1 << image.bits_per_sample) - 1 : 0);
    std::string why;
    if (!image.IsValid(&why)) throw InvalidArgumentError(what + ": " + why);
    images.push_back(std::move(image));
  }
  return images;
}

// The response as a (channels, levels) float64 array: row c is channel c's inverse response.
py::array_t<double> ResponseToArray(const calibration::CameraResponse& response) {
  py::array_t<double> out({static_cast<py::ssize_t>(response.channels()), static_cast<py::ssize_t>(response.levels)});
  auto view = out.mutable_unchecked<2>();
  for (int c = 0; c < response.channels(); ++c) {
    for (int z = 0; z < response.levels; ++z)
      view(c, z) = response.inverse[static_cast<std::size_t>(c)][static_cast<std::size_t>(z)];
  }
  return out;
}

calibration::CameraResponse ResponseFromArray(const py::array& array) {
  const auto values = ContiguousArray<double>(array, "response");
  if (values.ndim() != 2)
    throw InvalidArgumentError("response: expected a (channels, levels) array, as recover_response returns");
  calibration::CameraResponse response;
  response.levels = static_cast<int>(values.shape(1));
  const auto view = values.unchecked<2>();
  for (py::ssize_t c = 0; c < values.shape(0); ++c) {
    std::vector<double> row(static_cast<std::size_t>(response.levels));
    for (py::ssize_t z = 0; z < values.shape(1); ++z) row[static_cast<std::size_t>(z)] = view(c, z);
    response.inverse.push_back(std::move(row));
  }
  ThrowIfInvalid(response, "response");
  return response;
}

py::dict ResponseSummaryToDict(const calibration::ResponseSummary& s) {
  py::dict d;
  d["method"] = ToString(s.method);
  d["usable"] = s.usable;
  d["converged"] = s.converged;
  d["iterations"] = s.iterations;
  d["residual"] = s.residual;
  d["condition"] = s.condition;
  d["samples_used"] = s.samples_used;
  d["frames_used"] = s.frames_used;
  d["monotonic_fixes"] = s.monotonic_fixes;
  d["prior_disagreement"] =
      s.prior_disagreement ? py::object(py::float_(*s.prior_disagreement)) : py::object(py::none());
  d["low_confidence"] = s.low_confidence;
  d["reason"] = s.reason;
  d["brief"] = s.BriefReport();
  return d;
}

py::tuple RecoverResponse(const py::sequence& frames, const std::vector<double>& exposure_times_s,
                          const std::string& method, int sample_count, double smoothing_lambda,
                          const std::string& smoothness, int black_margin, int saturation_margin, std::uint64_t seed) {
  calibration::ResponseOptions options;
  options.method = calibration::ResponseMethodFromString(method);
  options.sample_count = sample_count;
  options.lambda = smoothing_lambda;
  options.smoothness = calibration::ResponseSmoothnessFromString(smoothness);
  options.black_margin = black_margin;
  options.saturation_margin = saturation_margin;
  options.seed = seed;
  ThrowIfInvalid(options, "recover_response");
  std::vector<py::array> keep;
  const std::vector<CameraImage> images = FramesFromArrays(frames, SampleLevels{}, &keep);
  calibration::ResponseResult result;
  {
    py::gil_scoped_release release;
    result = calibration::RecoverResponse(images, exposure_times_s, options);
  }
  return py::make_tuple(ResponseToArray(result.response), ResponseSummaryToDict(result.summary));
}

py::object MergeHdr(const py::sequence& frames, const std::vector<double>& exposure_times_s, const py::object& response,
                    int black_margin, int saturation_margin, bool weight_by_exposure, int threads, bool full_output,
                    std::optional<int> black_level, std::optional<int> white_level,
                    std::optional<int> bits_per_sample) {
  calibration::HdrMergeOptions options;
  options.black_margin = black_margin;
  options.saturation_margin = saturation_margin;
  options.weight_by_exposure = weight_by_exposure;
  options.threads = threads;
  ThrowIfInvalid(options, "merge_hdr");
  std::vector<py::array> keep;
  const std::vector<CameraImage> images =
      FramesFromArrays(frames, SampleLevels{black_level, white_level, bits_per_sample}, &keep);
  calibration::CameraResponse camera_response;
  if (py::isinstance<py::str>(response)) {
    if (response.cast<std::string>() != "linear") {
      throw InvalidArgumentError("merge_hdr: response '" + response.cast<std::string>() +
                                 "' is unknown; give recover_response's array or 'linear' (sensor-linear frames)");
    }
    if (images.empty()) throw InvalidArgumentError("merge_hdr: no frames");
    camera_response = calibration::SensorLinearResponse(images.front());
  } else {
    camera_response = ResponseFromArray(py::array::ensure(response));
  }
  calibration::HdrMergeResult result;
  {
    py::gil_scoped_release release;
    result = calibration::MergeHdr(images, exposure_times_s, camera_response, options);
  }
  py::array radiance = MatToArray(std::move(result.radiance.pixels));
  if (!full_output) return radiance;
  py::dict summary;
  summary["frames"] = result.summary.frames;
  summary["pixels"] = result.summary.pixels;
  summary["pixels_saturated_everywhere"] = result.summary.pixels_saturated_everywhere;
  summary["pixels_black_everywhere"] = result.summary.pixels_black_everywhere;
  summary["threads_used"] = result.summary.threads_used;
  summary["reason"] = result.summary.reason;
  summary["brief"] = result.summary.BriefReport();
  return py::make_tuple(radiance, MatToArray(std::move(result.status)), MatToArray(std::move(result.contributors)),
                        summary);
}

py::array LoadRadianceExr(const std::filesystem::path& path) {
  cv::Mat pixels;
  {
    py::gil_scoped_release release;
    pixels = calibration::LoadRadianceExr(path.string()).pixels;
  }
  return MatToArray(std::move(pixels));
}

}  // namespace

void BindHdr(py::module_& m) {
  m.def("load_radiance_exr", &LoadRadianceExr, "path"_a,
        "Reads a radiance EXR that relume wrote (a pipeline's radiance.exr, relit.exr, ...) as float32 HxWx3 "
        "(RGB) or HxW. Raises relume.IoError when it cannot be read.");
  const calibration::ResponseOptions response_defaults;
  m.def("recover_response", &RecoverResponse, "frames"_a, "exposure_times_s"_a, py::kw_only(),
        "method"_a = ToString(response_defaults.method), "sample_count"_a = response_defaults.sample_count,
        "smoothing_lambda"_a = response_defaults.lambda, "smoothness"_a = ToString(response_defaults.smoothness),
        "black_margin"_a = response_defaults.black_margin, "saturation_margin"_a = response_defaults.saturation_margin,
        "seed"_a = response_defaults.seed,
        R"doc(Recovers a camera's inverse response from a bracket of a static scene.

Args:
    frames: a sequence of uint8 arrays, HxWx3 (RGB) or HxW, all the same size: the camera's
        encoded output (not linear). C-contiguous arrays are read in place.
    exposure_times_s: each frame's exposure time in seconds (any order, > 0).
    method: 'debevec' (Debevec & Malik) or 'robertson'.
    sample_count: pixels sampled for the fit.
    smoothing_lambda: Debevec's smoothness weight (the C++ option `lambda`).
    smoothness: 'log-code' (power laws are free) or 'code' (Debevec's g'').
    black_margin, saturation_margin: codes within these of 0 / 255 get zero weight.
    seed: sample selection is deterministic for a given seed.

Returns:
    (response, summary): response is a float64 array (channels, 256), row c the relative
    exposure X(z) each code z of channel c stands for, X(128) = 1; summary a dict (usable,
    converged, residual, condition, samples_used, low_confidence, reason, brief, ...).
    A response with summary['usable'] False must not be used.

Raises:
    relume.InvalidArgumentError (a ValueError) for unusable input, with relume's message.
)doc");
  const calibration::HdrMergeOptions merge_defaults;
  m.def("merge_hdr", &MergeHdr, "frames"_a, "exposure_times_s"_a, "response"_a, py::kw_only(),
        "black_margin"_a = merge_defaults.black_margin, "saturation_margin"_a = merge_defaults.saturation_margin,
        "weight_by_exposure"_a = merge_defaults.weight_by_exposure, "threads"_a = merge_defaults.threads,
        "full_output"_a = false, "black_level"_a = py::none(), "white_level"_a = py::none(),
        "bits_per_sample"_a = py::none(),
        R"doc(Merges a bracket into linear radiance (Debevec & Malik eq. 6).

Args:
    frames: uint8 arrays, HxWx3 (RGB) or HxW, camera-encoded as for recover_response; or
        uint16 arrays of sensor-linear counts (raw, e.g. Session.load_image of a raw frame).
    exposure_times_s: each frame's exposure time in seconds (relative units are fine; relume's
        pipelines use t * ISO / 100).
    response: the (channels, levels) array recover_response returns, or 'linear' for
        sensor-linear uint16 frames (linear between black_level and white_level).
    black_margin, saturation_margin: codes within these of black / saturation get zero weight.
    weight_by_exposure: weight samples by exposure time as well (favours long exposures).
    threads: 0 = every core. The GIL is released while merging.
    full_output: also return the per-pixel status and contributors and a summary.
    black_level, white_level, bits_per_sample: how the samples are stored (a session frame's
        fields of the same names); default 0, the largest value and the dtype's bits.

Returns:
    radiance: float32 HxWx3 (or HxW), relative units X(z) / t, i.e. radiance up to one scale per
    channel. Pixels saturated in every frame hold the shortest frame's value (a lower bound).
    With full_output: (radiance, status uint8 HxW [0 good, 1 saturated everywhere, 2 black
    everywhere], contributors uint16 HxW [bit j: frame j contributed], summary dict).
)doc");
}

}  // namespace relume::python
