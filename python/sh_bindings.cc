// Spherical-harmonics lighting on numpy arrays (processing/sh.h, sh_fit.h, relight.h): fits of
// the 9 x 3 lighting coefficients from radiance and normals, irradiance, and relighting by the
// ratio of irradiances. Conventions are the library's (processing/sh.h): coefficient k =
// l (l + 1) + m, real orthonormal basis without the Condon-Shortley phase, directions in the
// camera frame, irradiance E(n) = sum_k A_l L_k Y_k(n), Lambertian radiance albedo E / pi.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/error.h"
#include "processing/nonneg_light.h"
#include "processing/relight.h"
#include "processing/segmentation.h"
#include "processing/sh.h"
#include "processing/sh_fit.h"
#include "python/bindings.h"
#include "python/convert.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

py::array_t<double> LightToArray(const processing::ShRgb& light) {
  py::array_t<double> out({processing::kShCount, 3});
  auto view = out.mutable_unchecked<2>();
  for (int k = 0; k < processing::kShCount; ++k) {
    for (int c = 0; c < 3; ++c) view(k, c) = light(k, c);
  }
  return out;
}

processing::ShRgb LightFromArray(const py::handle& array, const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!a || a.ndim() != 2 || a.shape(1) != 3 || a.shape(0) < 1 || a.shape(0) > processing::kShCount) {
    throw InvalidArgumentError(what +
                               ": expected a (9, 3) array of SH coefficients (rows k = l (l + 1) + m, "
                               "columns R, G, B; 1 or 4 rows for orders 0 and 1)");
  }
  processing::ShRgb light = processing::ShRgb::Zero();
  for (py::ssize_t k = 0; k < a.shape(0); ++k) {
    for (int c = 0; c < 3; ++c) light(static_cast<int>(k), c) = a.at(k, c);
  }
  if (!light.allFinite()) throw InvalidArgumentError(what + ": coefficients must be finite");
  return light;
}

py::dict SummaryToPython(const processing::ShFitSummary& s) {
  return py::dict("usable"_a = s.usable, "order_used"_a = s.order_used, "order_reduced"_a = s.order_reduced,
                  "observation_count"_a = s.observation_count, "condition_number"_a = s.condition_number,
                  "condition_number_order2"_a = s.condition_number_order2,
                  "normal_solid_angle_sr"_a = s.normal_solid_angle_sr,
                  "relative_rms_residual"_a = s.relative_rms_residual,
                  "albedo_light_condition_number"_a = s.albedo_light_condition_number, "iterations"_a = s.iterations,
                  "converged"_a = s.converged, "message"_a = s.message, "brief"_a = s.BriefReport());
}

cv::Mat LabelsFromPython(const py::handle& labels, py::array* keep) {
  const py::array a = py::array::ensure(labels);
  if (!a || a.ndim() != 2) throw InvalidArgumentError("labels: expected an HxW int32 array");
  *keep = ContiguousArray<std::int32_t>(a, "labels");
  return cv::Mat(static_cast<int>(keep->shape(0)), static_cast<int>(keep->shape(1)), CV_32SC1,
                 const_cast<void*>(keep->data()));
}

// The observations at every pixel of `mask` (all pixels without one).
std::vector<processing::ShObservation> Observations(const py::object& radiance, const py::object& normals,
                                                    const py::object& albedo, const py::object& labels,
                                                    const py::object& mask) {
  py::array keep[4];
  const RadianceImage image = RadianceFromArray(radiance, "radiance", &keep[0]);
  const cv::Mat normal = FloatMatFromArray(normals, 3, "normals", &keep[1]);
  const cv::Mat albedo_mat = albedo.is_none() ? cv::Mat() : FloatMatFromArray(albedo, 3, "albedo", &keep[2]);
  const cv::Mat labels_mat = labels.is_none() ? cv::Mat() : LabelsFromPython(labels, &keep[3]);
  py::array mask_keep;
  const cv::Mat mask_mat = MaskFromPython(mask, "mask", &mask_keep);
  if (!mask_mat.empty() && mask_mat.size() != image.pixels.size()) {
    throw InvalidArgumentError("mask: expected the radiance image's size");
  }
  std::vector<cv::Point> points;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      if (mask_mat.empty() || mask_mat.at<std::uint8_t>(y, x) != 0) points.emplace_back(x, y);
    }
  }
  std::vector<processing::ShObservation> observations;
  {
    py::gil_scoped_release release;
    observations = processing::GatherObservations(image, normal, albedo_mat, labels_mat, points);
  }
  return observations;
}

processing::ShFitOptions FitOptions(int max_order, double max_condition_number, double min_solid_angle_order2_sr,
                                    int min_observations_per_coefficient) {
  processing::ShFitOptions options;
  options.max_order = max_order;
  options.max_condition_number = max_condition_number;
  options.min_solid_angle_order2_sr = min_solid_angle_order2_sr;
  options.min_observations_per_coefficient = min_observations_per_coefficient;
  return options;
}

py::tuple FitSh(const py::object& radiance, const py::object& normals, const py::object& albedo, const py::object& mask,
                int max_order, double max_condition_number, double min_solid_angle_order2_sr,
                int min_observations_per_coefficient) {
  const processing::ShFitOptions options =
      FitOptions(max_order, max_condition_number, min_solid_angle_order2_sr, min_observations_per_coefficient);
  ThrowIfInvalid(options, "fit_sh");
  const auto observations = Observations(radiance, normals, albedo, py::none(), mask);
  processing::ShFitResult result;
  {
    py::gil_scoped_release release;
    result = processing::FitShKnownAlbedo(observations, options);
  }
  return py::make_tuple(LightToArray(result.light), SummaryToPython(result.summary));
}

py::tuple FitShUnknownAlbedo(const py::object& radiance, const py::object& normals, const py::object& labels,
                             const py::object& mask, int max_iterations, double tolerance,
                             int min_observations_per_segment, int reference_segment,
                             const py::object& reference_albedo, int max_order, double max_condition_number,
                             double min_solid_angle_order2_sr, int min_observations_per_coefficient) {
  processing::ShAlbedoFitOptions options;
  options.fit =
      FitOptions(max_order, max_condition_number, min_solid_angle_order2_sr, min_observations_per_coefficient);
  options.max_iterations = max_iterations;
  options.tolerance = tolerance;
  options.min_observations_per_segment = min_observations_per_segment;
  options.reference_segment = reference_segment;
  options.reference_albedo = Vector3FromPython(reference_albedo, "reference_albedo");
  ThrowIfInvalid(options, "fit_sh_unknown_albedo");
  const auto observations = Observations(radiance, normals, py::none(), labels, mask);
  processing::ShAlbedoFitResult result;
  {
    py::gil_scoped_release release;
    result = processing::FitShUnknownAlbedo(observations, options);
  }
  py::array_t<double> albedo({static_cast<py::ssize_t>(result.segment_albedo.size()), py::ssize_t{3}});
  auto view = albedo.mutable_unchecked<2>();
  py::array_t<bool> used(static_cast<py::ssize_t>(result.segment_used.size()));
  for (std::size_t s = 0; s < result.segment_albedo.size(); ++s) {
    for (int c = 0; c < 3; ++c) view(static_cast<py::ssize_t>(s), c) = result.segment_albedo[s][c];
    used.mutable_at(static_cast<py::ssize_t>(s)) = result.segment_used[s];
  }
  py::dict summary = SummaryToPython(result.summary);
  summary["reference_segment"] = result.reference_segment;
  summary["segment_used"] = used;
  return py::make_tuple(LightToArray(result.light), albedo, summary);
}

// Applies `per_normal` to every 3-vector of an (..., 3) array of unit directions.
template <typename F>
py::array_t<double> MapDirections(const py::object& directions, const char* what, F per_normal) {
  const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(directions);
  if (!d || d.ndim() < 1 || d.shape(d.ndim() - 1) != 3) {
    throw InvalidArgumentError(std::string(what) + ": expected an (..., 3) array of unit directions");
  }
  std::vector<py::ssize_t> shape(d.shape(), d.shape() + d.ndim());
  py::array_t<double> out(shape);
  const double* in = d.data();
  double* o = out.mutable_data();
  const py::ssize_t n = d.size() / 3;
  {
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < n; ++i) {
      const Eigen::Vector3d v = per_normal(Eigen::Vector3d(in[3 * i], in[3 * i + 1], in[3 * i + 2]));
      for (int c = 0; c < 3; ++c) o[3 * i + c] = v[c];
    }
  }
  return out;
}

py::array_t<double> ShIrradiance(const py::object& light, const py::object& normals) {
  const processing::ShRgb l = LightFromArray(light, "light");
  return MapDirections(normals, "normals", [&](const Eigen::Vector3d& n) { return processing::ShIrradiance(l, n); });
}

py::array_t<double> ShRadiance(const py::object& light, const py::object& directions) {
  const processing::ShRgb l = LightFromArray(light, "light");
  return MapDirections(directions, "directions",
                       [&](const Eigen::Vector3d& w) { return processing::ShRadiance(l, w); });
}

processing::RelightOptions RelightOptionsOf(double min_irradiance_fraction, int ratio_radius_px,
                                            double ratio_spatial_sigma_px, double ratio_range_sigma,
                                            double max_albedo_deviation, const char* what) {
  processing::RelightOptions options;
  options.max_albedo_deviation = max_albedo_deviation;
  options.min_irradiance_fraction = min_irradiance_fraction;
  options.ratio_radius_px = ratio_radius_px;
  options.ratio_spatial_sigma_px = ratio_spatial_sigma_px;
  options.ratio_range_sigma = ratio_range_sigma;
  ThrowIfInvalid(options, what);
  return options;
}

// relight(image, normals, mask) -> RelightResult, without the GIL; the arrays and summary as
// relight_sh and relight_nonnegative return them.
template <typename Relight>
py::tuple RelightArrays(const py::object& source, const py::object& normals, const py::object& mask,
                        const Relight& relight) {
  py::array keep[3];
  const RadianceImage image = RadianceFromArray(source, "source", &keep[0]);
  const cv::Mat normal = FloatMatFromArray(normals, 3, "normals", &keep[1]);
  const cv::Mat mask_mat = MaskFromPython(mask, "mask", &keep[2]);
  processing::RelightResult result;
  {
    py::gil_scoped_release release;
    result = relight(image, normal, mask_mat);
  }
  const processing::RelightSummary& s = result.summary;
  py::dict summary("requested_pixel_count"_a = s.requested_pixel_count, "relit_pixel_count"_a = s.relit_pixel_count,
                   "guarded_pixel_count"_a = s.guarded_pixel_count, "invalid_input_count"_a = s.invalid_input_count,
                   "albedo_replaced_pixel_count"_a = s.albedo_replaced_pixel_count, "message"_a = s.message);
  return py::make_tuple(MatToArray(std::move(result.relit.pixels)),
                        MatToArray(std::move(result.valid)).attr("astype")("bool"), summary);
}

py::tuple RelightSh(const py::object& source, const py::object& normals, const py::object& source_light,
                    const py::object& target_light, const py::object& mask, double min_irradiance_fraction,
                    int ratio_radius_px, double ratio_spatial_sigma_px, double ratio_range_sigma,
                    double max_albedo_deviation) {
  const processing::RelightOptions options =
      RelightOptionsOf(min_irradiance_fraction, ratio_radius_px, ratio_spatial_sigma_px, ratio_range_sigma,
                       max_albedo_deviation, "relight_sh");
  const processing::ShRgb src_light = LightFromArray(source_light, "source_light");
  const processing::ShRgb dst_light = LightFromArray(target_light, "target_light");
  return RelightArrays(source, normals, mask, [&](const RadianceImage& image, const cv::Mat& n, const cv::Mat& m) {
    return processing::RelightSh(image, n, m, src_light, dst_light, options);
  });
}

// A non-negative light from Python: (directions (K, 3), irradiance (K, 3)).
processing::NonNegativeLight NonNegativeLightFromPython(const py::handle& light, const std::string& what) {
  const auto bad = [&] {
    return InvalidArgumentError(what +
                                ": expected (directions, irradiance), two (K, 3) float arrays as "
                                "fit_nonnegative_light returns");
  };
  if (!py::isinstance<py::tuple>(light) && !py::isinstance<py::list>(light)) throw bad();
  const py::sequence pair = py::reinterpret_borrow<py::sequence>(light);
  if (pair.size() != 2) throw bad();
  const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(pair[0]);
  const auto w = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(pair[1]);
  if (!d || !w || d.ndim() != 2 || w.ndim() != 2 || d.shape(1) != 3 || w.shape(1) != 3 || d.shape(0) != w.shape(0))
    throw bad();
  processing::NonNegativeLight out;
  for (py::ssize_t j = 0; j < d.shape(0); ++j) {
    out.directions.emplace_back(d.at(j, 0), d.at(j, 1), d.at(j, 2));
    out.irradiance.emplace_back(w.at(j, 0), w.at(j, 1), w.at(j, 2));
  }
  return out;
}

py::array_t<double> Rows(const std::vector<Eigen::Vector3d>& rows) {
  py::array_t<double> out({static_cast<py::ssize_t>(rows.size()), py::ssize_t{3}});
  for (std::size_t j = 0; j < rows.size(); ++j) {
    for (int c = 0; c < 3; ++c) out.mutable_at(static_cast<py::ssize_t>(j), c) = rows[j](c);
  }
  return out;
}

py::tuple FitNonNegativeLight(const py::object& radiance, const py::object& normals, const py::object& albedo,
                              const py::object& mask, int direction_count, int min_observations, double ridge,
                              int outlier_rounds, double outlier_mads, double min_outlier_residual) {
  processing::NonNegativeLightOptions options;
  options.direction_count = direction_count;
  options.min_observations = min_observations;
  options.ridge = ridge;
  options.outlier_rounds = outlier_rounds;
  options.outlier_mads = outlier_mads;
  options.min_outlier_residual = min_outlier_residual;
  ThrowIfInvalid(options, "fit_nonnegative_light");
  const auto observations = Observations(radiance, normals, albedo, py::none(), mask);
  processing::NonNegativeLightResult result;
  {
    py::gil_scoped_release release;
    result = processing::FitNonNegativeLight(observations, options);
  }
  const processing::NonNegativeLightSummary& s = result.summary;
  py::dict summary("usable"_a = s.usable, "observation_count"_a = s.observation_count,
                   "outlier_count"_a = s.outlier_count, "active_direction_count"_a = s.active_direction_count,
                   "relative_rms_residual"_a = s.relative_rms_residual, "iterations"_a = s.iterations,
                   "converged"_a = s.converged, "message"_a = s.message, "brief"_a = s.BriefReport());
  return py::make_tuple(py::make_tuple(Rows(result.light.directions), Rows(result.light.irradiance)), summary);
}

py::tuple RelightNonNegative(const py::object& source, const py::object& normals, const py::object& source_light,
                             const py::object& target_light, const py::object& mask, double min_irradiance_fraction,
                             int ratio_radius_px, double ratio_spatial_sigma_px, double ratio_range_sigma,
                             double max_albedo_deviation) {
  const processing::RelightOptions options =
      RelightOptionsOf(min_irradiance_fraction, ratio_radius_px, ratio_spatial_sigma_px, ratio_range_sigma,
                       max_albedo_deviation, "relight_nonnegative");
  const processing::NonNegativeLight src_light = NonNegativeLightFromPython(source_light, "source_light");
  const processing::NonNegativeLight dst_light = NonNegativeLightFromPython(target_light, "target_light");
  return RelightArrays(source, normals, mask, [&](const RadianceImage& image, const cv::Mat& n, const cv::Mat& m) {
    return processing::RelightNonNegative(image, n, m, src_light, dst_light, options);
  });
}

py::tuple SegmentByColor(const py::object& radiance, const py::object& mask, const py::object& normals,
                         int segment_count, bool use_normals, double normal_weight, int max_cluster_pixels,
                         int attempts, int max_iterations, std::uint64_t seed) {
  processing::SegmentationOptions options;
  options.segment_count = segment_count;
  options.use_normals = use_normals;
  options.normal_weight = normal_weight;
  options.max_cluster_pixels = max_cluster_pixels;
  options.attempts = attempts;
  options.max_iterations = max_iterations;
  options.seed = seed;
  ThrowIfInvalid(options, "segment_by_color");
  py::array keep[3];
  const RadianceImage image = RadianceFromArray(radiance, "radiance", &keep[0]);
  cv::Mat mask_mat = MaskFromPython(mask, "mask", &keep[1]);
  if (mask_mat.empty()) mask_mat = cv::Mat(image.pixels.size(), CV_8UC1, cv::Scalar(1));  // None: every pixel
  const cv::Mat normal = normals.is_none() ? cv::Mat() : FloatMatFromArray(normals, 3, "normals", &keep[2]);
  if (use_normals && normal.empty()) throw InvalidArgumentError("segment_by_color: use_normals needs normals");
  processing::Segmentation segmentation;
  {
    py::gil_scoped_release release;
    segmentation = processing::SegmentByColor(image, mask_mat, normal, options);
  }
  py::array_t<double> mean({static_cast<py::ssize_t>(segmentation.mean_color.size()), py::ssize_t{3}});
  for (std::size_t s = 0; s < segmentation.mean_color.size(); ++s) {
    for (int c = 0; c < 3; ++c) mean.mutable_at(static_cast<py::ssize_t>(s), c) = segmentation.mean_color[s][c];
  }
  return py::make_tuple(MatToArray(std::move(segmentation.labels)), segmentation.pixel_count, mean);
}

constexpr const char* kFitArgs =
    R"doc(    max_order: highest SH order fitted (0, 1 or 2); lower when the normals do not support it.
    max_condition_number: largest condition number of the basis matrix per order.
    min_solid_angle_order2_sr: steradians the normals must cover for order 2.
    min_observations_per_coefficient: pixels needed per coefficient.)doc";

}  // namespace

void BindSh(py::module_& m) {
  const processing::ShFitOptions f;
  m.def("fit_sh", &FitSh, "radiance"_a, "normals"_a, py::kw_only(), "albedo"_a = py::none(), "mask"_a = py::none(),
        "max_order"_a = f.max_order, "max_condition_number"_a = f.max_condition_number,
        "min_solid_angle_order2_sr"_a = f.min_solid_angle_order2_sr,
        "min_observations_per_coefficient"_a = f.min_observations_per_coefficient,
        (std::string(R"doc(Fits SH lighting to Lambertian pixels of known albedo (processing/sh_fit.h).

Model: radiance = albedo * E(n) / pi, E(n) = sum_k A_l L_k Y_k(n) (processing/sh.h), one linear
least-squares problem per channel; the order drops (and the summary says why) when the normals'
coverage or conditioning do not support it.

Args:
    radiance: float32 HxWx3 linear RGB.
    normals: float32 HxWx3 unit normals in the camera frame (estimate_normals), NaN = none.
    albedo: float32 HxWx3 per-pixel albedo, or None for 1 (then L is albedo * light).
    mask: HxW bool/uint8, the pixels to use (None: every pixel with a finite normal and
        non-negative radiance).
)doc") + kFitArgs +
         R"doc(

Returns:
    (light, summary): light float64 (9, 3), rows k = l (l + 1) + m, columns R, G, B, the
    radiance coefficients L_k (zero above the order used); summary dict (usable, order_used,
    order_reduced, observation_count, condition_number, normal_solid_angle_sr,
    relative_rms_residual, converged, message, brief). usable False: no light was estimated.
)doc")
            .c_str());
  const processing::ShAlbedoFitOptions a;
  m.def("fit_sh_unknown_albedo", &FitShUnknownAlbedo, "radiance"_a, "normals"_a, "labels"_a, py::kw_only(),
        "mask"_a = py::none(), "max_iterations"_a = a.max_iterations, "tolerance"_a = a.tolerance,
        "min_observations_per_segment"_a = a.min_observations_per_segment, "reference_segment"_a = a.reference_segment,
        "reference_albedo"_a =
            std::vector<double>{a.reference_albedo.x(), a.reference_albedo.y(), a.reference_albedo.z()},
        "max_order"_a = f.max_order, "max_condition_number"_a = f.max_condition_number,
        "min_solid_angle_order2_sr"_a = f.min_solid_angle_order2_sr,
        "min_observations_per_coefficient"_a = f.min_observations_per_coefficient,
        (std::string(R"doc(Fits SH lighting and per-segment albedo together (Ogura et al.; processing/sh_fit.h).

Light and albedo are updated in turn until the coefficients change by less than tolerance
(relative). Only albedo * light is determined: each channel's scale is fixed by declaring the
reference segment's albedo to be reference_albedo.

Args:
    radiance, normals, mask: as for fit_sh.
    labels: int32 HxW segment of uniform albedo per pixel (0, 1, ...; negative: not used).
    max_iterations, tolerance: the alternation's stop.
    min_observations_per_segment: smaller segments are left out.
    reference_segment: the segment whose albedo is declared (-1: the largest).
    reference_albedo: its albedo, (R, G, B).
)doc") + kFitArgs +
         R"doc(

Returns:
    (light, segment_albedo, summary): light float64 (9, 3) as fit_sh's; segment_albedo
    float64 (segments, 3) (zero for segments left out); summary as fit_sh's plus
    reference_segment and segment_used (bool per segment). Its
    albedo_light_condition_number says how well the pixels tell the light from the albedos
    (large: segments show too few orientations; NaN for fit_sh).
)doc")
            .c_str());
  const processing::SegmentationOptions g;
  m.def("segment_by_color", &SegmentByColor, "radiance"_a, py::kw_only(), "mask"_a = py::none(),
        "normals"_a = py::none(), "segment_count"_a = g.segment_count, "use_normals"_a = g.use_normals,
        "normal_weight"_a = g.normal_weight, "max_cluster_pixels"_a = g.max_cluster_pixels, "attempts"_a = g.attempts,
        "max_iterations"_a = g.max_iterations, "seed"_a = g.seed,
        R"doc(Regions of uniform albedo by k-means on chromaticity (processing/segmentation.h): the
labels fit_sh_unknown_albedo takes.

Args:
    radiance: float32 HxWx3 linear RGB.
    mask: HxW bool/uint8, the pixels to segment (None: all).
    normals: float32 HxWx3 camera-frame normals (needed with use_normals).
    segment_count: k.
    use_normals, normal_weight: append the normal, times normal_weight, to the features.
    max_cluster_pixels, attempts, max_iterations, seed: k-means runs on at most this many
        pixels (then every pixel joins its nearest centre), its restarts and iterations, and
        the deterministic sample's seed.

Returns:
    (labels int32 HxW: 0 the largest segment, -1 outside the mask or unusable; pixel_count per
    label, descending; mean_color float64 (segments, 3)).
)doc");
  m.def("sh_irradiance", &ShIrradiance, "light"_a, "normals"_a,
        R"doc(Irradiance E(n) = sum_k A_l L_k Y_k(n) (A0 = pi, A1 = 2 pi / 3, A2 = pi / 4) for SH lighting.

Args:
    light: (9, 3) radiance coefficients (fit_sh's; 1 or 4 rows for orders 0 and 1).
    normals: (..., 3) unit normals in the light's frame.

Returns:
    float64 (..., 3): E per channel, in the light's radiance units times steradians.
)doc");
  m.def("sh_radiance", &ShRadiance, "light"_a, "directions"_a,
        "The band-limited light's radiance L(w) = sum_k L_k Y_k(w) toward (..., 3) unit directions w (pointing from "
        "the surface to the light): float64 (..., 3).");
  m.def("relight_sh", &RelightSh, "source"_a, "normals"_a, "source_light"_a, "target_light"_a, py::kw_only(),
        "mask"_a = py::none(), "min_irradiance_fraction"_a = processing::RelightOptions{}.min_irradiance_fraction,
        "ratio_radius_px"_a = processing::RelightOptions{}.ratio_radius_px,
        "ratio_spatial_sigma_px"_a = processing::RelightOptions{}.ratio_spatial_sigma_px,
        "ratio_range_sigma"_a = processing::RelightOptions{}.ratio_range_sigma,
        "max_albedo_deviation"_a = processing::RelightOptions{}.max_albedo_deviation,
        R"doc(Relights by the ratio of SH irradiances (Ogura & Saito eq. 7): I_t = I_s E_t(n) / E_s(n).

Args:
    source: float32 HxWx3 linear RGB radiance.
    normals: float32 HxWx3 unit normals in the camera frame (the lights' frame).
    source_light, target_light: (9, 3) SH radiance coefficients (fit_sh).
    mask: HxW bool/uint8, the pixels to relight (None: all).
    min_irradiance_fraction: a pixel whose source irradiance in some channel is below this
        fraction of that channel's mean source irradiance over the pixels is not divided.
    ratio_radius_px, ratio_spatial_sigma_px, ratio_range_sigma: the ratio E_t / E_s is filtered
        by a joint bilateral filter over the relit pixels, guided by the source's log
        luminance (range sigma in its natural log), which averages the error of noisy normals
        without crossing shading edges. ratio_radius_px=0: each pixel by its own ratio (exact
        for exact normals and lights). For normals from noisy depth (a Kinect-like sensor) the
        sh pipeline filters wider: ratio_radius_px=6, ratio_spatial_sigma_px=4.0,
        ratio_range_sigma=0.03 (RelightOptions::noisy_ratio_*).

    max_albedo_deviation: the shading check: a pixel whose implied albedo I_s / E_s(n) is more
        than this factor above the median of its neighbours' of the same chromaticity (7x7) is
        brighter than its normal can explain (a face seen edge-on, given the normal of the face
        beside it); it is relit as that median albedo times E_t(n) instead of being multiplied
        by the ratio. 0: off.

Returns:
    (relit float32 HxWx3, NaN where not relit; valid bool HxW; summary dict with
    requested_pixel_count, relit_pixel_count, guarded_pixel_count (irradiance too small),
    invalid_input_count (no normal or non-finite colour), albedo_replaced_pixel_count (the
    shading check), message).
)doc");
  const processing::NonNegativeLightOptions nn;
  m.def("fit_nonnegative_light", &FitNonNegativeLight, "radiance"_a, "normals"_a, py::kw_only(),
        "albedo"_a = py::none(), "mask"_a = py::none(), "direction_count"_a = nn.direction_count,
        "min_observations"_a = nn.min_observations, "ridge"_a = nn.ridge, "outlier_rounds"_a = nn.outlier_rounds,
        "outlier_mads"_a = nn.outlier_mads, "min_outlier_residual"_a = nn.min_outlier_residual,
        R"doc(Fits a non-negative directional light: E(n) = sum_j w_j max(0, n . d_j), w_j >= 0 per channel, on
a Fibonacci grid of directions (processing/nonneg_light.h). Unlike order-2 SH it follows a lamp's or the
sun's terminator; relight with relight_nonnegative.

Args:
    radiance: float32 HxWx3 linear RGB radiance.
    normals: float32 HxWx3 unit normals in the camera frame.
    albedo: float32 HxWx3 per-pixel albedo (None: 1).
    mask: HxW bool/uint8, the pixels to fit (None: all). Every masked pixel is an observation, and the
        fit's cost grows with them: a few thousand sampled pixels are enough (the library samples 2000).
    direction_count: directions of the grid (512: about 9 deg apart).
    min_observations: fewer observations give an unusable fit.
    ridge: added to the normal equations' diagonal, relative to its mean.
    outlier_rounds, outlier_mads, min_outlier_residual: refits without the pixels whose residual
        |I - model| (relative to the mean |I|) is above min_outlier_residual and median + outlier_mads
        x 1.4826 MAD (wrong normals at silhouettes and creases).

Returns:
    ((directions float64 (K, 3), irradiance float64 (K, 3)): the K directions with a positive weight
    and their RGB irradiance on a plane facing them; summary dict with usable, observation_count,
    outlier_count, active_direction_count, relative_rms_residual, iterations, converged, message, brief).
)doc");
  m.def("relight_nonnegative", &RelightNonNegative, "source"_a, "normals"_a, "source_light"_a, "target_light"_a,
        py::kw_only(), "mask"_a = py::none(),
        "min_irradiance_fraction"_a = processing::RelightOptions{}.min_irradiance_fraction,
        "ratio_radius_px"_a = processing::RelightOptions{}.ratio_radius_px,
        "ratio_spatial_sigma_px"_a = processing::RelightOptions{}.ratio_spatial_sigma_px,
        "ratio_range_sigma"_a = processing::RelightOptions{}.ratio_range_sigma,
        "max_albedo_deviation"_a = processing::RelightOptions{}.max_albedo_deviation,
        R"doc(Relights by the ratio of non-negative lights' irradiances, as relight_sh does with SH lights.

Args:
    source, normals, mask, min_irradiance_fraction, ratio_*, max_albedo_deviation: as relight_sh.
    source_light, target_light: (directions, irradiance) pairs as fit_nonnegative_light returns.

Returns:
    as relight_sh.
)doc");
}

}  // namespace relume::python
