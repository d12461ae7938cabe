// Depth filtering and normals from depth on numpy arrays (processing/depth_filter.h,
// processing/normals.h): float32 HxW depth in metres along z (NaN, <= 0 or Inf: a hole) in, the
// library's results out. C-contiguous float32 arrays are read in place; the GIL is released.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "core/error.h"
#include "processing/depth_filter.h"
#include "processing/normals.h"
#include "python/bindings.h"
#include "python/convert.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

py::array BilateralFilterDepth(const py::object& depth_m, int radius_px, double spatial_sigma_px,
                               double range_sigma_at_1m_m, double edge_cut_sigmas) {
  processing::BilateralDepthOptions options;
  options.radius_px = radius_px;
  options.spatial_sigma_px = spatial_sigma_px;
  options.range_sigma_at_1m_m = range_sigma_at_1m_m;
  options.edge_cut_sigmas = edge_cut_sigmas;
  ThrowIfInvalid(options, "bilateral_filter_depth");
  py::array keep;
  const cv::Mat depth = FloatMatFromArray(depth_m, 1, "depth_m", &keep);
  cv::Mat filtered;
  {
    py::gil_scoped_release release;
    filtered = processing::BilateralFilterDepth(depth, options);
  }
  return MatToArray(std::move(filtered));
}

py::tuple TemporalFilterDepth(const py::object& current_m, const py::object& previous_m, double weight,
                              double max_difference_sigmas, double range_sigma_at_1m_m) {
  processing::TemporalDepthOptions options;
  options.weight = weight;
  options.max_difference_sigmas = max_difference_sigmas;
  options.range_sigma_at_1m_m = range_sigma_at_1m_m;
  ThrowIfInvalid(options, "temporal_filter_depth");
  py::array keep[2];
  const cv::Mat current = FloatMatFromArray(current_m, 1, "current_m", &keep[0]);
  const cv::Mat previous = previous_m.is_none() ? cv::Mat() : FloatMatFromArray(previous_m, 1, "previous_m", &keep[1]);
  if (!previous.empty() && previous.size() != current.size()) {
    throw InvalidArgumentError("temporal_filter_depth: previous_m is " + std::to_string(previous.cols) + "x" +
                               std::to_string(previous.rows) + ", current_m " + std::to_string(current.cols) + "x" +
                               std::to_string(current.rows));
  }
  cv::Mat blended;
  int blended_count = 0;
  {
    py::gil_scoped_release release;
    blended = processing::TemporalFilterDepth(current, previous, options, &blended_count);
  }
  return py::make_tuple(MatToArray(std::move(blended)), blended_count);
}

py::dict EstimateDepthNoise(const py::object& depth_m, double edge_jump_fraction) {
  if (!(edge_jump_fraction > 0.0)) throw InvalidArgumentError("estimate_depth_noise: edge_jump_fraction must be > 0");
  py::array keep;
  const cv::Mat depth = FloatMatFromArray(depth_m, 1, "depth_m", &keep);
  processing::DepthNoiseEstimate e;
  {
    py::gil_scoped_release release;
    e = processing::EstimateDepthNoise(depth, edge_jump_fraction);
  }
  return py::dict("sigma_at_1m_m"_a = e.sigma_at_1m_m, "samples"_a = e.samples, "valid_pixels"_a = e.valid_pixels,
                  "stair_fraction"_a = e.stair_fraction,
                  "noise_free"_a = e.NoiseFree(processing::kDenoiseSkipBelowAt1mM), "describe"_a = e.Describe());
}

py::dict EstimateNormals(const py::object& depth_m, const py::dict& intrinsics, int window_radius_px,
                         double depth_change_ratio, double min_valid_fraction, double plane_step_tolerance,
                         bool refine_creases, double refine_creases_below_noise_at_1m_m, int min_window_radius_px,
                         bool neighbour_boxes_on_noisy_depth, int jet_radius_px, double jet_max_residual,
                         bool depth_noisy) {
  processing::NormalOptions options;
  options.window_radius_px = window_radius_px;
  options.min_window_radius_px = min_window_radius_px;
  options.neighbour_boxes_on_noisy_depth = neighbour_boxes_on_noisy_depth;
  options.jet_radius_px = jet_radius_px;
  options.jet_max_residual = jet_max_residual;
  options.depth_noisy = depth_noisy;
  options.depth_change_ratio = depth_change_ratio;
  options.min_valid_fraction = min_valid_fraction;
  options.plane_step_tolerance = plane_step_tolerance;
  options.refine_creases = refine_creases;
  options.refine_creases_below_noise_at_1m_m = refine_creases_below_noise_at_1m_m;
  ThrowIfInvalid(options, "estimate_normals");
  const PinholeIntrinsics k = IntrinsicsFromPython(intrinsics, "intrinsics");
  py::array keep;
  const cv::Mat depth = FloatMatFromArray(depth_m, 1, "depth_m", &keep);
  processing::NormalMap map;
  {
    py::gil_scoped_release release;
    map = processing::EstimateNormals(depth, k, options);
  }
  return py::dict("normals"_a = MatToArray(std::move(map.normal_in_camera)),
                  "valid"_a = MatToArray(std::move(map.valid)).attr("astype")("bool"),
                  "method"_a = MatToArray(std::move(map.method)), "integral_count"_a = map.integral_count,
                  "cross_count"_a = map.cross_count, "crease_count"_a = map.crease_count,
                  "neighbour_box_count"_a = map.neighbour_box_count, "jet_count"_a = map.jet_count,
                  "invalid_count"_a = map.invalid_count,
                  "creases_skipped_for_noise"_a = map.creases_skipped_for_noise
                                                      ? py::object(py::str(map.creases_skipped_for_noise->Describe()))
                                                      : py::object(py::none()));
}

py::array VertexMap(const py::object& depth_m, const py::dict& intrinsics) {
  const PinholeIntrinsics k = IntrinsicsFromPython(intrinsics, "intrinsics");
  py::array keep;
  const cv::Mat depth = FloatMatFromArray(depth_m, 1, "depth_m", &keep);
  if (depth.cols != k.width || depth.rows != k.height) {
    throw InvalidArgumentError("vertex_map: depth_m is " + std::to_string(depth.cols) + "x" +
                               std::to_string(depth.rows) + ", the intrinsics " + std::to_string(k.width) + "x" +
                               std::to_string(k.height));
  }
  cv::Mat vertices;
  {
    py::gil_scoped_release release;
    vertices = processing::VertexMap(depth, k);
  }
  return MatToArray(std::move(vertices));
}

}  // namespace

void BindDepth(py::module_& m) {
  const processing::BilateralDepthOptions b;
  m.def("bilateral_filter_depth", &BilateralFilterDepth, "depth_m"_a, py::kw_only(), "radius_px"_a = b.radius_px,
        "spatial_sigma_px"_a = b.spatial_sigma_px, "range_sigma_at_1m_m"_a = b.range_sigma_at_1m_m,
        "edge_cut_sigmas"_a = b.edge_cut_sigmas,
        R"doc(Edge-preserving bilateral filter of a depth map (Ogura & Saito 2015, eq. 1).

Args:
    depth_m: float32 HxW, metres along the optical axis; NaN, <= 0 or Inf is a hole and stays
        one (no pixel is ever filled).
    radius_px: window half-size in pixels (window (2 r + 1)^2).
    spatial_sigma_px: the spatial Gaussian's sigma, pixels.
    range_sigma_at_1m_m: the range Gaussian's sigma at 1 m, metres; it grows as z^2.
    edge_cut_sigmas: neighbours further than this many range sigmas from the centre get weight
        0 (no averaging across depth discontinuities).

Returns:
    float32 HxW, metres. Raises relume.InvalidArgumentError for invalid options.
)doc");
  const processing::TemporalDepthOptions t;
  m.def("temporal_filter_depth", &TemporalFilterDepth, "current_m"_a, "previous_m"_a, py::kw_only(),
        "weight"_a = t.weight, "max_difference_sigmas"_a = t.max_difference_sigmas,
        "range_sigma_at_1m_m"_a = t.range_sigma_at_1m_m,
        R"doc(Two-frame temporal depth filter (Ogura & Saito 2015, eq. 2).

D = (D_t (w + 1) + D_{t-1} w) / (2 w + 1) where both frames are valid and differ by at most
max_difference_sigmas range sigmas (range_sigma_at_1m_m * z^2, metres); elsewhere D_t.

Args:
    current_m, previous_m: float32 HxW depth in metres (the previous frame's bilateral
        output, as the paper does); previous_m may be None (first frame: D_t is returned).
    weight: w above (0 disables the blend).
    max_difference_sigmas, range_sigma_at_1m_m: the blend's gate.

Returns:
    (depth_m float32 HxW, blended_pixels int).
)doc");
  m.def("estimate_depth_noise", &EstimateDepthNoise, "depth_m"_a, "edge_jump_fraction"_a = 0.02,
        R"doc(A depth map's own noise, without a reference (processing/depth_filter.h).

Fourth differences along rows and columns (cancelling any locally cubic surface), each divided
by sqrt(70) z^2: the noise at 1 m under the z^2 law, metres (the unit of range_sigma_at_1m_m).
A window is used only when its five samples are valid and within edge_jump_fraction of the
centre's depth.

Returns:
    dict: sigma_at_1m_m (NaN when not measurable), samples, valid_pixels, stair_fraction (share
    of sloped rows with quantisation stairs), noise_free (below the SH pipeline's skip
    threshold, 5e-5 m), describe (the sentence the pipeline logs).
)doc");
  const processing::NormalOptions n;
  m.def("estimate_normals", &EstimateNormals, "depth_m"_a, "intrinsics"_a, py::kw_only(),
        "window_radius_px"_a = n.window_radius_px, "depth_change_ratio"_a = n.depth_change_ratio,
        "min_valid_fraction"_a = n.min_valid_fraction, "plane_step_tolerance"_a = n.plane_step_tolerance,
        "refine_creases"_a = n.refine_creases,
        "refine_creases_below_noise_at_1m_m"_a = n.refine_creases_below_noise_at_1m_m,
        "min_window_radius_px"_a = n.min_window_radius_px,
        "neighbour_boxes_on_noisy_depth"_a = n.neighbour_boxes_on_noisy_depth, "jet_radius_px"_a = n.jet_radius_px,
        "jet_max_residual"_a = n.jet_max_residual, "depth_noisy"_a = n.depth_noisy,
        R"doc(Surface normals from a depth map and pinhole intrinsics (processing/normals.h).

Integral-image box averages of the vertex map (Holzer et al. 2012); where the box touches a
depth discontinuity, smaller centred boxes; where none fits, the cross product of neighbour
differences (Ogura & Saito eq. 3), on noisy depth first the neighbours' 3 x 3 boxes; on depth
without noise those pixels' normals are refined by a quadratic jet (Cazals & Pouget 2003). Beside a
crease (two planes meeting, depth continuous) on noise-free depth the normal of a 3 x 3 box on
the pixel's own face.

Args:
    depth_m: float32 HxW, metres along z; NaN, <= 0 or Inf is a hole.
    intrinsics: dict {'width', 'height', 'fx', 'fy', 'cx', 'cy'} in pixels (pixel centres at
        +0.5; Session.camera's dict works), of the depth map's size.
    window_radius_px: r: boxes of (2 r + 1) x r pixels; 0: cross products only.
    depth_change_ratio: |dz| / z above which 4-neighbours are on different surfaces, unless
        the step continues a plane (a ground seen at a grazing angle).
    plane_step_tolerance: such a step continues a plane when its step in inverse depth w is
        within this many w of the steps before and after it (0: never).
    min_valid_fraction: of each half box, for the smooth estimate.
    refine_creases: where the box is not planar, the most planar 3 x 3 box with the pixel on
        its border gives the normal (a box's edges). For depth without noise: on noisy depth
        the small fits follow the noise, at 50x the cost (the SH pipeline turns it off when it
        filters depth).
    refine_creases_below_noise_at_1m_m: with refine_creases or neighbour_boxes_on_noisy_depth,
        the depth's own noise is measured first (estimate_depth_noise, ~12 ms at 640x480): creases
        are refined and jets fitted only when it is noise-free below this (metres at 1 m), the
        neighbours' boxes used only when it is not; 0: noise-free without measuring.
    min_window_radius_px: where the window's box does not fit, centred boxes down to this radius
        are tried first (window_radius_px: none).
    neighbour_boxes_on_noisy_depth: on noisy depth, where no centred box fits, the mean tangents
        of the 3 x 3 boxes centred on the pixel's neighbours, before one-pixel differences (which
        are mostly noise there).
    jet_radius_px: on depth without noise, where the window's box does not fit, the normal of a
        quadratic height field fitted to the pixel's surface within this radius (0: off).
    jet_max_residual: the jet is kept when its RMS residual is at most this share of its points'
        RMS distance to the pixel.
    depth_noisy: the caller knows the depth is noisy: no measurement, no crease refinement, no
        jets.

Returns:
    dict: 'normals' float32 HxWx3, unit, camera frame (x right, y down, z forward), facing the
    camera (n . p < 0), NaN where invalid; 'valid' bool HxW; 'method' uint8 HxW (0 invalid,
    1 integral image, 2 neighbour cross product, 3 crease box, 4 neighbours' boxes, 5 jet);
    'integral_count', 'cross_count', 'crease_count', 'neighbour_box_count', 'jet_count',
    'invalid_count' (pixels with depth but no normal);
    'creases_skipped_for_noise': None, or the measured noise (a sentence) when refine_creases
    was asked for but the depth is not noise-free.
)doc");
  m.def("vertex_map", &VertexMap, "depth_m"_a, "intrinsics"_a,
        "The camera-frame point of every pixel, z * ((u + 0.5 - cx) / fx, (v + 0.5 - cy) / fy, 1): float32 HxWx3 "
        "metres, NaN at holes. intrinsics as for estimate_normals.");
}

}  // namespace relume::python
