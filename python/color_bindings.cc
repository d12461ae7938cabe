// The ColorChecker on numpy arrays (calibration/colorchecker_detect.h, colorchecker_fit.h):
// detection on an 8-bit preview, patch sampling on linear values, and the fit of a per-channel
// piecewise-linear gain and a 3x3 colour matrix with CIEDE2000 per patch; the steps
// `relume calibrate chart` takes. Patches are 24, in reading order (dark skin first).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "calibration/calibration_profile.h"
#include "calibration/colorchecker_detect.h"
#include "calibration/colorchecker_fit.h"
#include "calibration/report_plots.h"
#include "core/color.h"
#include "core/error.h"
#include "python/bindings.h"
#include "python/convert.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

constexpr int kPatches = 24;

ColorCheckerReference Reference(const std::filesystem::path& path) {
  return LoadColorCheckerReference(path.string());
}

py::dict ReferenceToPython(const std::filesystem::path& path) {
  const ColorCheckerReference r = Reference(path);
  py::list names;
  std::vector<Eigen::Vector3d> lab, rgb;
  for (const ColorCheckerPatch& p : r.patches) {
    names.append(p.name);
    lab.push_back(p.lab_d50);
    rgb.push_back(p.linear_rgb);
  }
  return py::dict("name"_a = r.name, "names"_a = names, "lab_d50"_a = Vectors3dToArray(lab),
                  "linear_rgb"_a = Vectors3dToArray(rgb), "neutral_indices"_a = r.NeutralIndices());
}

cv::Mat Rgb8FromArray(const py::object& array, const std::string& what, py::array* keep) {
  const py::array a = py::array::ensure(array);
  if (!a || a.ndim() != 3 || a.shape(2) != 3)
    throw InvalidArgumentError(what + ": expected an HxWx3 uint8 array (RGB)");
  *keep = ContiguousArray<std::uint8_t>(a, what);
  return MatView(*keep, what);
}

py::array_t<float> CornersToArray(const std::array<cv::Point2f, 4>& corners) {
  py::array_t<float> out({4, 2});
  auto view = out.mutable_unchecked<2>();
  for (int k = 0; k < 4; ++k) {
    view(k, 0) = corners[static_cast<std::size_t>(k)].x;
    view(k, 1) = corners[static_cast<std::size_t>(k)].y;
  }
  return out;
}

std::vector<cv::Point2f> CornersFromPython(const py::object& corners) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(corners);
  if (!a || a.ndim() != 2 || a.shape(1) != 2) throw InvalidArgumentError("corners: expected a (4, 2) array of (x, y)");
  std::vector<cv::Point2f> points;
  for (py::ssize_t k = 0; k < a.shape(0); ++k) {
    points.emplace_back(static_cast<float>(a.at(k, 0)), static_cast<float>(a.at(k, 1)));
  }
  return points;
}

py::dict LocationToPython(const calibration::ChartLocation& l) {
  return py::dict("found"_a = l.found, "method"_a = l.method, "corners"_a = CornersToArray(l.corners),
                  "orientation_score"_a = l.orientation_score, "reason"_a = l.reason);
}

py::dict DetectColorChecker(const py::object& preview, const std::filesystem::path& reference,
                            const std::string& detector, int min_patch_side_px) {
  calibration::ChartDetectOptions options;
  options.detector = calibration::ChartDetectorFromString(detector);
  options.min_patch_side_px = min_patch_side_px;
  ThrowIfInvalid(options, "detect_colorchecker");
  const ColorCheckerReference ref = Reference(reference);
  py::array keep;
  const cv::Mat rgb8 = Rgb8FromArray(preview, "preview", &keep);
  calibration::ChartLocation location;
  {
    py::gil_scoped_release release;
    location = calibration::DetectColorChecker(rgb8, ref, options);
  }
  return LocationToPython(location);
}

py::dict ChartFromCorners(const py::object& corners, const py::object& preview,
                          const std::filesystem::path& reference) {
  const ColorCheckerReference ref = Reference(reference);
  py::array keep;
  const cv::Mat rgb8 = Rgb8FromArray(preview, "preview", &keep);
  return LocationToPython(calibration::ChartFromCorners(CornersFromPython(corners), rgb8, ref));
}

py::dict SamplePatches(const py::object& values, const py::object& corners, const py::object& clipped,
                       double inner_fraction, int samples_per_side, double max_spread) {
  calibration::PatchSampleOptions options;
  options.inner_fraction = inner_fraction;
  options.samples_per_side = samples_per_side;
  options.max_spread = max_spread;
  ThrowIfInvalid(options, "sample_patches");
  const std::vector<cv::Point2f> points = CornersFromPython(corners);
  if (points.size() != 4)
    throw InvalidArgumentError("corners: expected 4 points, got " + std::to_string(points.size()));
  calibration::ChartLocation location;
  location.found = true;
  location.method = "manual";
  std::copy(points.begin(), points.end(), location.corners.begin());
  py::array keep[2];
  calibration::ChartImage image;
  image.values = FloatMatFromArray(values, 3, "values", &keep[0]);
  image.clipped = MaskFromPython(clipped, "clipped", &keep[1]);
  if (!image.clipped.empty() && image.clipped.size() != image.values.size()) {
    throw InvalidArgumentError("clipped: expected the values' size");
  }
  std::vector<calibration::PatchSample> samples;
  {
    py::gil_scoped_release release;
    samples = calibration::SamplePatches(image, location, options);
  }
  py::array_t<double> median({static_cast<py::ssize_t>(samples.size()), py::ssize_t{3}});
  py::array_t<double> spread(static_cast<py::ssize_t>(samples.size()));
  py::array_t<float> quads({static_cast<py::ssize_t>(samples.size()), py::ssize_t{4}, py::ssize_t{2}});
  py::list status;
  auto m = median.mutable_unchecked<2>();
  auto q = quads.mutable_unchecked<3>();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto k = static_cast<py::ssize_t>(i);
    for (int c = 0; c < 3; ++c) m(k, c) = samples[i].median[c];
    spread.mutable_at(k) = samples[i].spread;
    for (int j = 0; j < 4; ++j) {
      q(k, j, 0) = samples[i].inner_quad[static_cast<std::size_t>(j)].x;
      q(k, j, 1) = samples[i].inner_quad[static_cast<std::size_t>(j)].y;
    }
    status.append(calibration::ToString(samples[i].status));
  }
  return py::dict("median"_a = median, "spread"_a = spread, "status"_a = status, "inner_quads"_a = quads);
}

calibration::PatchStatus StatusFromString(const std::string& name) {
  using calibration::PatchStatus;
  for (PatchStatus s : {PatchStatus::kOk, PatchStatus::kSaturated, PatchStatus::kBlack, PatchStatus::kNonUniform,
                        PatchStatus::kOutside}) {
    if (name == calibration::ToString(s)) return s;
  }
  throw InvalidArgumentError("status: '" + name +
                             "' is unknown; expected ok, saturated, black, non-uniform or outside");
}

py::dict FitColorChecker(const py::object& measured, const std::filesystem::path& reference, const py::object& status,
                         bool fit_gain, bool fit_matrix, bool white_preserving, double ridge, double max_condition,
                         double max_mean_delta_e) {
  calibration::ColorFitOptions options;
  options.fit_gain = fit_gain;
  options.fit_matrix = fit_matrix;
  options.white_preserving = white_preserving;
  options.ridge = ridge;
  options.max_condition = max_condition;
  options.max_mean_delta_e = max_mean_delta_e;
  ThrowIfInvalid(options, "fit_colorchecker");
  const ColorCheckerReference ref = Reference(reference);
  const std::vector<Eigen::Vector3d> values = Vectors3dFromArray(measured, "measured");
  if (values.size() != kPatches) {
    throw InvalidArgumentError("measured: expected 24 patches (reading order), got " + std::to_string(values.size()));
  }
  std::vector<calibration::PatchSample> patches(kPatches);
  for (int k = 0; k < kPatches; ++k) {
    patches[static_cast<std::size_t>(k)].median = cv::Vec3d(values[k].x(), values[k].y(), values[k].z());
  }
  if (!status.is_none()) {
    const auto names = status.cast<std::vector<std::string>>();
    if (names.size() != kPatches) throw InvalidArgumentError("status: expected 24 entries (sample_patches' status)");
    for (int k = 0; k < kPatches; ++k) patches[static_cast<std::size_t>(k)].status = StatusFromString(names[k]);
  }
  calibration::ColorFit fit;
  {
    py::gil_scoped_release release;
    fit = calibration::FitColorChecker(patches, ref, options);
  }
  std::vector<Eigen::Vector3d> corrected, lab;
  py::array_t<double> delta_e(kPatches);
  py::array_t<bool> used(kPatches);
  for (int k = 0; k < kPatches; ++k) {
    const calibration::PatchFit& p = fit.patches[static_cast<std::size_t>(k)];
    corrected.push_back(p.corrected);
    lab.push_back(p.corrected_lab);
    delta_e.mutable_at(k) = p.delta_e;
    used.mutable_at(k) = p.used;
  }
  py::array_t<double> ccm({3, 3});
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) ccm.mutable_at(r, c) = fit.ccm(r, c);
  }
  py::list gain;
  for (std::size_t c = 0; c < 3; ++c) {
    gain.append(
        py::dict("x"_a = py::array_t<double>(static_cast<py::ssize_t>(fit.gain.x[c].size()), fit.gain.x[c].data()),
                 "y"_a = py::array_t<double>(static_cast<py::ssize_t>(fit.gain.y[c].size()), fit.gain.y[c].data())));
  }
  const calibration::ColorFitSummary& s = fit.summary;
  py::dict summary("usable"_a = s.usable, "low_confidence"_a = s.low_confidence, "patches_used"_a = s.patches_used,
                   "neutrals_used"_a = s.neutrals_used, "condition"_a = s.condition, "residual_rms"_a = s.residual_rms,
                   "mean_delta_e"_a = s.mean_delta_e, "max_delta_e"_a = s.max_delta_e, "reason"_a = s.reason,
                   "brief"_a = s.BriefReport());
  return py::dict("ccm"_a = ccm, "gain"_a = gain, "corrected"_a = Vectors3dToArray(corrected),
                  "corrected_lab"_a = Vectors3dToArray(lab), "delta_e"_a = delta_e, "used"_a = used,
                  "summary"_a = summary);
}

py::array PreviewLinear(const py::object& values) {
  py::array keep;
  const cv::Mat linear = FloatMatFromArray(values, 3, "values", &keep);
  cv::Mat preview;
  {
    py::gil_scoped_release release;
    preview = calibration::PreviewLinear(linear);
  }
  return MatToArray(std::move(preview));
}

py::array_t<double> DeltaE2000(const py::object& lab_a, const py::object& lab_b) {
  const std::vector<Eigen::Vector3d> a = Vectors3dFromArray(lab_a, "lab_a");
  const std::vector<Eigen::Vector3d> b = Vectors3dFromArray(lab_b, "lab_b");
  if (a.size() != b.size()) throw InvalidArgumentError("delta_e_2000: lab_a and lab_b differ in length");
  py::array_t<double> out(static_cast<py::ssize_t>(a.size()));
  for (std::size_t i = 0; i < a.size(); ++i)
    out.mutable_at(static_cast<py::ssize_t>(i)) = calibration::DeltaE2000(a[i], b[i]);
  return out;
}

py::array ApplyColorProfile(const py::object& radiance, const py::object& profile) {
  calibration::CalibrationProfile p;
  if (py::isinstance<py::dict>(profile)) {
    const std::string text = py::module_::import("json").attr("dumps")(profile).cast<std::string>();
    p = calibration::ProfileFromJson(text, "the profile dict");
  } else {
    p = calibration::LoadProfile(profile.cast<std::filesystem::path>().string());
  }
  py::array keep;
  RadianceImage image = RadianceFromArray(radiance, "radiance", &keep);
  RadianceImage corrected;
  {
    py::gil_scoped_release release;
    corrected = calibration::ApplyProfile(p, image);
  }
  return MatToArray(std::move(corrected.pixels));
}

constexpr const char* kReferenceArg =
    "    reference: the chart's reference data, a YAML file (relume's config/colorchecker/"
    "xrite_classic_2014_lab_d50.yaml, the CLI's --reference default).\n";

}  // namespace

void BindColor(py::module_& m) {
  m.def("load_colorchecker_reference", &ReferenceToPython, "path"_a,
        R"doc(A ColorChecker's reference data (config/colorchecker/*.yaml).

Returns:
    dict: name, names (24, reading order), lab_d50 float64 (24, 3) (L*, a*, b*, D50),
    linear_rgb float64 (24, 3) (reflectance in linear sRGB, D65), neutral_indices (white first).
Raises relume.ConfigError / relume.IoError naming the file and key.
)doc");
  const calibration::ChartDetectOptions d;
  m.def("detect_colorchecker", &DetectColorChecker, "preview"_a, "reference"_a, py::kw_only(),
        "detector"_a = calibration::ToString(d.detector), "min_patch_side_px"_a = d.min_patch_side_px,
        (std::string(R"doc(Finds a 24-patch ColorChecker in an 8-bit RGB image (calibration/colorchecker_detect.h).

Args:
    preview: uint8 HxWx3 RGB: camera output, or preview_linear(radiance).
)doc") + kReferenceArg +
         R"doc(    detector: 'auto' (OpenCV's mcc, then relume's lattice detector), 'mcc' or 'lattice'.
    min_patch_side_px: lattice: smaller squares are ignored (pixels).

Returns:
    dict: found, method, corners float32 (4, 2) (x, y) image positions of chart grid (0,0),
    (6,0), (6,4), (0,4) (dark skin's corner first; pixel (x, y) covers [x, x+1)),
    orientation_score, reason (why not found).
)doc")
            .c_str());
  m.def(
      "chart_from_corners", &ChartFromCorners, "corners"_a, "preview"_a, "reference"_a,
      "The chart from four user-given corners (x, y) in pixels, any order and start: ordered around their centre, the "
      "orientation chosen like a detector's. Returns detect_colorchecker's dict. Raises relume.InvalidArgumentError "
      "unless there are 4 finite, distinct, convex points.");
  const calibration::PatchSampleOptions s;
  m.def("sample_patches", &SamplePatches, "values"_a, "corners"_a, py::kw_only(), "clipped"_a = py::none(),
        "inner_fraction"_a = s.inner_fraction, "samples_per_side"_a = s.samples_per_side, "max_spread"_a = s.max_spread,
        R"doc(Measures the 24 patches (calibration/colorchecker_detect.h SamplePatches).

Args:
    values: float32 HxWx3 linear values (merged radiance, or codes / white level).
    corners: (4, 2) the chart's corners as detect_colorchecker returns them.
    clipped: HxW uint8/bool, non-zero where a pixel must not be used (saturated or black), or None.
    inner_fraction: side of the sampled square relative to the patch pitch.
    samples_per_side: grid of sample points inside it.
    max_spread: above this relative spread a patch is 'non-uniform'.

Returns:
    dict: median float64 (24, 3) per channel, spread (24,) (median absolute deviation / median,
    largest channel), status (24 strings: ok, saturated, black, non-uniform, outside),
    inner_quads float32 (24, 4, 2) (the sampled regions).
)doc");
  const calibration::ColorFitOptions f;
  m.def("fit_colorchecker", &FitColorChecker, "measured"_a, "reference"_a, py::kw_only(), "status"_a = py::none(),
        "fit_gain"_a = f.fit_gain, "fit_matrix"_a = f.fit_matrix, "white_preserving"_a = f.white_preserving,
        "ridge"_a = f.ridge, "max_condition"_a = f.max_condition, "max_mean_delta_e"_a = f.max_mean_delta_e,
        (std::string(R"doc(Fits a camera's colour to the chart (calibration/colorchecker_fit.h).

A per-channel piecewise-linear gain through (0, 0) and the six neutral patches (Troccoli &
Allen), then a 3x3 colour matrix by least squares in linear RGB, then CIEDE2000 per patch.

Args:
    measured: (24, 3) patch values in reading order (sample_patches' median): linear radiance
        or codes scaled to [0, 1].
)doc") + kReferenceArg +
         R"doc(    status: 24 strings from sample_patches (patches not 'ok' are left out), or None (all used).
    fit_gain, fit_matrix: fit each part (else identity).
    white_preserving: the matrix maps the (gain-corrected) white patch exactly.
    ridge: pull toward the identity, relative to the patches' mean square.
    max_condition, max_mean_delta_e: above these the fit is low-confidence.

Returns:
    dict: ccm float64 (3, 3) (applied after the gain, to column vectors), gain (per channel
    {'x': measured knots, 'y': linear values}), corrected float64 (24, 3) (linear sRGB, chart
    reflectance units), corrected_lab (24, 3) (D50), delta_e (24,) (CIEDE2000; 0 for unused),
    used bool (24,), summary (usable, low_confidence, patches_used, neutrals_used, condition,
    residual_rms, mean_delta_e, max_delta_e, reason, brief).
)doc")
            .c_str());
  m.def("apply_color_profile", &ApplyColorProfile, "radiance"_a, "profile"_a,
        R"doc(Applies a calibration profile's gain and 3x3 colour matrix to linear radiance.

Args:
    radiance: float32 HxWx3 linear RGB (merge_hdr's); NaN stays NaN.
    profile: a profile JSON file (`relume calibrate chart --out`), or its parsed JSON as a dict
        (a Session.calibrations entry's 'data' of kind 'profile').

Returns:
    float32 HxWx3: per pixel gain (piecewise linear per channel), then the matrix: what
    `relume process` applies when the session holds the device's profile.
)doc");
  m.def("preview_linear", &PreviewLinear, "values"_a,
        "An 8-bit sRGB preview of linear float32 HxWx3 values scaled so that their 99th percentile maps to 1: the "
        "image `relume calibrate chart` detects the chart on. Returns uint8 HxWx3.");
  m.def("delta_e_2000", &DeltaE2000, "lab_a"_a, "lab_b"_a,
        "CIEDE2000 colour differences (Sharma, Wu & Dalal 2005; kL = kC = kH = 1) between (N, 3) arrays of L*a*b*: "
        "float64 (N,).");
}

}  // namespace relume::python
