// relume.irm_relight and relume.enu_direction: relighting a photograph with irradiance ratio maps
// (processing/irm/relight.h RelightImage: the same three steps as `relume process --pipeline irm`,
// per-vertex visibility and sun fractions of each photograph, the IRMs, every source pixel
// relit) on numpy radiance, a mesh and two cameras.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <cstdio>
#include <deque>
#include <string>

#include "core/error.h"
#include "core/frames.h"
#include "core/site.h"
#include "processing/geometry/ray_caster.h"
#include "processing/irm/relight.h"
#include "python/bindings.h"
#include "python/convert.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

irm::FillMethod FillFromString(const std::string& name) {
  for (irm::FillMethod m : {irm::FillMethod::kNone, irm::FillMethod::kSmoothing, irm::FillMethod::kSunSkyModel}) {
    if (name == irm::ToString(m)) return m;
  }
  throw InvalidArgumentError("irm_relight: fill='" + name + "' is unknown; expected none, smoothing or sun_sky_model");
}

py::array_t<double> EnuDirection(double azimuth_deg, double elevation_deg) {
  const Eigen::Vector3d d = EnuDirectionFromAzimuthElevation(DegToRad(azimuth_deg), DegToRad(elevation_deg));
  py::array_t<double> out(3);
  for (int i = 0; i < 3; ++i) out.mutable_at(i) = d[i];
  return out;
}

py::object Vec(const Eigen::Vector3f& v) {
  return py::make_tuple(v.x(), v.y(), v.z());
}

// One ratio map as bins x bins arrays (row j, column i: bin j * bins + i of the octahedral square).
py::dict MapToPython(const irm::RatioMap& map) {
  const py::ssize_t n = map.bins;
  py::array_t<float> ratio({n, n, py::ssize_t{3}});
  py::array_t<std::int32_t> count({n, n});
  py::array_t<std::uint8_t> source({n, n});
  for (py::ssize_t b = 0; b < n * n; ++b) {
    const auto k = static_cast<std::size_t>(b);
    for (int c = 0; c < 3; ++c) ratio.mutable_data()[3 * b + c] = map.ratio[k][c];
    count.mutable_data()[b] = map.count[k];
    source.mutable_data()[b] = map.source[k];
  }
  return py::dict("ratio"_a = ratio, "count"_a = count, "source"_a = source, "measured_bins"_a = map.measured_bins());
}

py::dict IrmSetToPython(const irm::IrmSet& set) {
  const irm::SunSkyModel& model = set.model;
  py::list measured;
  py::dict maps;
  for (int k = 0; k < 4; ++k) {
    const irm::RatioMap& map = set.maps[static_cast<std::size_t>(k)];
    measured.append(map.measured_bins());
    maps[irm::ToString(static_cast<irm::MapKind>(k))] = MapToPython(map);
  }
  return py::dict("single_map"_a = set.single_map, "samples_used"_a = set.samples_used,
                  "samples_in_penumbra"_a = set.samples_in_penumbra, "samples_too_dark"_a = set.samples_too_dark,
                  "measured_bins"_a = measured, "maps"_a = maps, "summary"_a = set.summary,
                  "model"_a = py::dict("valid"_a = model.valid, "sun_source"_a = Vec(model.sun_source),
                                       "sun_target"_a = Vec(model.sun_target), "sky_target"_a = Vec(model.sky_target),
                                       "sky_gradient_source"_a = Vec(model.sky_gradient_source),
                                       "sky_gradient_target"_a = Vec(model.sky_gradient_target),
                                       "rms_relative_residual"_a = model.rms_relative_residual,
                                       "condition_number"_a = model.condition_number, "reason"_a = model.reason));
}

// The summary under the names relume process writes in summary.json's metrics['irm'].
py::dict SummaryToPython(const irm::RelightSummary& s) {
  return py::dict(
      "vertices"_a = s.vertices, "visible_in_both"_a = s.visible_in_both, "consistent_samples"_a = s.consistent_samples,
      "irm_summary"_a = s.irm_summary, "pixels_relit"_a = s.pixels_relit,
      "pixels_without_geometry"_a = s.pixels_without_geometry, "pixels_without_ratio"_a = s.pixels_without_ratio,
      "pixels_masked"_a = s.pixels_masked, "pixels_with_own_sun_rays"_a = s.pixels_with_own_sun_rays,
      "pixels_with_own_sky_rays"_a = s.pixels_with_own_sky_rays,
      "pixels_with_own_indirect_rays"_a = s.pixels_with_own_indirect_rays, "indirect_rays"_a = s.indirect_rays,
      "indirect_hit_share"_a = s.indirect_hit_share, "indirect_filled_source"_a = s.indirect_filled_source,
      "indirect_filled_target"_a = s.indirect_filled_target, "overlap_vertex_rms_before"_a = s.overlap_rms_before,
      "overlap_vertex_rms_after"_a = s.overlap_rms_after, "preprocess_s"_a = s.preprocess_s, "build_s"_a = s.build_s,
      "relight_s"_a = s.relight_s);
}

py::dict IrmRelight(const py::dict& mesh, const py::object& source_radiance, const py::object& target_radiance,
                    const py::dict& source_camera, const py::dict& target_camera, const py::object& source_sun_dir,
                    const py::object& target_sun_dir, const py::object& source_mask, const py::object& target_mask,
                    int bins, float lit_threshold, float shadow_threshold, int min_samples_per_bin, float trim_fraction,
                    float min_source_radiance, const std::string& fill, bool model_correction,
                    bool single_map_without_shadow, float smoothing_sigma_rad, int sun_samples, int sky_samples,
                    bool sky_gradient, float sun_angular_radius_rad, bool penumbra, bool exact_shadow_edges,
                    bool indirect, int indirect_samples, int indirect_passes, int threads) {
  irm::RelightOptions options;
  options.irm.bins = bins;
  options.irm.lit_threshold = lit_threshold;
  options.irm.shadow_threshold = shadow_threshold;
  options.irm.min_samples_per_bin = min_samples_per_bin;
  options.irm.trim_fraction = trim_fraction;
  options.irm.min_source_radiance = min_source_radiance;
  options.irm.fill = FillFromString(fill);
  options.irm.model_correction = model_correction;
  options.irm.single_map_without_shadow = single_map_without_shadow;
  options.irm.smoothing_sigma_rad = smoothing_sigma_rad;
  options.sun_samples = sun_samples;
  options.sky_samples = sky_samples;
  options.sky_gradient = sky_gradient;
  options.sun_angular_radius_rad = sun_angular_radius_rad;
  options.use_penumbra_fractions = penumbra;
  options.exact_shadow_edges = exact_shadow_edges;
  options.indirect = indirect;
  options.indirect_samples = indirect_samples;
  options.indirect_passes = indirect_passes;
  options.threads = threads;
  ThrowIfInvalid(options, "irm_relight");

  TriangleMesh triangles = MeshFromPython(mesh, "mesh");
  if (triangles.normals.empty()) triangles.ComputeVertexNormals();
  py::array keep[4];
  const RadianceImage source_image = RadianceFromArray(source_radiance, "source_radiance", &keep[0]);
  const RadianceImage target_image = RadianceFromArray(target_radiance, "target_radiance", &keep[1]);
  // The pipeline's directions are float casts of the double ENU direction: the same here.
  const irm::View source{&source_image, CameraFromPython(source_camera, "source_camera"),
                         Vector3FromPython(source_sun_dir, "source_sun_dir").cast<float>(),
                         MaskFromPython(source_mask, "source_mask", &keep[2])};
  const irm::View target{&target_image, CameraFromPython(target_camera, "target_camera"),
                         Vector3FromPython(target_sun_dir, "target_sun_dir").cast<float>(),
                         MaskFromPython(target_mask, "target_mask", &keep[3])};
  irm::RelightResult result;
  {
    py::gil_scoped_release release;
    const RayCaster caster(std::move(triangles));
    result = irm::RelightImage(caster, source, target, options);
  }
  return py::dict("relit"_a = MatToArray(std::move(result.relit.pixels)), "status"_a = MatToArray(result.status),
                  "source_sun"_a = MatToArray(result.source_sun), "target_sun"_a = MatToArray(result.target_sun),
                  "summary"_a = SummaryToPython(result.summary), "irms"_a = IrmSetToPython(result.irms));
}

// A float default as help() shows it: its shortest decimal form (0.99, not 0.9900000095367432).
// pybind11 keeps the pointer, so the texts live as long as the module.
const char* Short(float value) {
  static std::deque<std::string> texts;
  char text[32];
  std::snprintf(text, sizeof(text), "%g", static_cast<double>(value));
  return texts.emplace_back(text).c_str();
}

}  // namespace

void BindIrm(py::module_& m) {
  m.def("enu_direction", &EnuDirection, "azimuth_deg"_a, "elevation_deg"_a,
        R"doc(The unit direction toward a body at (azimuth, elevation) in the site's East-North-Up frame.

Args:
    azimuth_deg: degrees clockwise from true north (a frame's sun_azimuth_deg).
    elevation_deg: degrees above the horizon (a frame's sun_elevation_deg).

Returns:
    float64 array (3,): (east, north, up), unit length; what irm_relight takes as a sun
    direction for a mesh in ENU (Session.scene_mesh), computed as `relume process` computes it.
)doc");
  const irm::RelightOptions d;
  m.def("irm_relight", &IrmRelight, "mesh"_a, "source_radiance"_a, "target_radiance"_a, "source_camera"_a,
        "target_camera"_a, "source_sun_dir"_a, "target_sun_dir"_a, py::kw_only(), "source_mask"_a = py::none(),
        "target_mask"_a = py::none(), "bins"_a = d.irm.bins,
        py::arg_v("lit_threshold", d.irm.lit_threshold, Short(d.irm.lit_threshold)),
        py::arg_v("shadow_threshold", d.irm.shadow_threshold, Short(d.irm.shadow_threshold)),
        "min_samples_per_bin"_a = d.irm.min_samples_per_bin,
        py::arg_v("trim_fraction", d.irm.trim_fraction, Short(d.irm.trim_fraction)),
        py::arg_v("min_source_radiance", d.irm.min_source_radiance, Short(d.irm.min_source_radiance)),
        "fill"_a = irm::ToString(d.irm.fill), "model_correction"_a = d.irm.model_correction,
        "single_map_without_shadow"_a = d.irm.single_map_without_shadow,
        py::arg_v("smoothing_sigma_rad", d.irm.smoothing_sigma_rad, Short(d.irm.smoothing_sigma_rad)),
        "sun_samples"_a = d.sun_samples, "sky_samples"_a = d.sky_samples, "sky_gradient"_a = d.sky_gradient,
        py::arg_v("sun_angular_radius_rad", d.sun_angular_radius_rad, Short(d.sun_angular_radius_rad)),
        "penumbra"_a = d.use_penumbra_fractions, "exact_shadow_edges"_a = d.exact_shadow_edges,
        "indirect"_a = d.indirect, "indirect_samples"_a = d.indirect_samples, "indirect_passes"_a = d.indirect_passes,
        "threads"_a = d.threads,
        R"doc(Relights a photograph to another's light with irradiance ratio maps (Troccoli & Allen).

The library's RelightImage (processing/irm/relight.h): per-vertex visibility and sun
fractions of each photograph, the four IRMs tied by a sun + sky model from the vertices both
photographs see, then every source pixel times the ratio for its surface normal and sun
fractions (its camera ray cast into the mesh). The same computation as
`relume process --pipeline irm` with the same settings. The GIL is released while it runs.

Args:
    mesh: dict {'positions' (N, 3) float32 metres, 'triangles' (M, 3) int32, 'normals'
        (N, 3) float32 unit per vertex or None (then area-weighted from the triangles),
        optionally 'parts' (N,) int32, the object each vertex belongs to (for the reflectance
        of surfaces no photograph shows) or None}, in the frame of the cameras and sun
        directions (ENU at the site: Session.scene_mesh).
    source_radiance, target_radiance: linear radiance, float32 HxWx3 (RGB), each of its
        camera's size (merge_hdr; relative units are fine, ratios are per channel).
    source_camera, target_camera: dicts {'width', 'height', 'fx', 'fy', 'cx', 'cy' (pixels),
        'world_from_camera' (4x4; camera x right, y down, z forward)} (Session.camera).
    source_sun_dir, target_sun_dir: unit vectors toward the sun in the mesh's frame when each
        photograph was taken (enu_direction(frame's azimuth, elevation)).
    source_mask, target_mask: HxW bool/uint8, True where the radiance is not to be trusted
        (merge_hdr's status != 0); never sampled, and masked source pixels stay untouched.
    bins: octahedral normal bins per side of each ratio map (the `bins` knob).
    lit_threshold, shadow_threshold: sun fractions at/above which a sample is lit, at/below
        which it is in shadow.
    min_samples_per_bin, trim_fraction: a bin with fewer samples is empty; the share dropped
        at each end of a bin's robust mean.
    min_source_radiance: smaller source radiance gives no ratio.
    fill: how empty bins are filled: 'sun_sky_model', 'smoothing' or 'none'.
    model_correction: carry a bin's ratio to the pixel's normal with the sun + sky model.
    single_map_without_shadow: one map when no sample is in cast shadow.
    smoothing_sigma_rad: kernel width of fill='smoothing' (radians).
    sun_samples: rays per vertex over the sun's disk; sky_samples: cosine-weighted rays per
        vertex for its sky view (0: every surface open to the sky).
    sky_gradient: measure the sky's brightness against elevation in each photograph.
    sun_angular_radius_rad: the sun's angular radius (radians).
    penumbra: fractional sun visibility (False: the paper's 0/1 bits).
    exact_shadow_edges: pixels on triangles a shadow edge crosses cast their own sun rays (and
        their own sky-view and indirect-light rays where those change fast across a triangle).
    indirect: gather each surface's light from the other surfaces out of the photographs
        (interreflection, docs/irm.md) and fit it into the sun + sky model; kept only when it
        explains the samples better than the model without it.
    indirect_samples: cosine-weighted rays per vertex for it.
    indirect_passes: refinements of the radiance of surfaces no photograph shows.
    threads: worker threads, 0 = the CPUs this process may use (no effect on the results).

Returns:
    dict: 'relit' float32 HxWx3 (the source under the target's light; untouched where status
    is not 1), 'status' uint8 HxW (0 no geometry, 1 relit, 2 no ratio, 3 masked),
    'source_sun', 'target_sun' float32 HxW (per-pixel sun fractions, NaN without geometry),
    'summary' (counts and overlap errors under the names of summary.json's metrics['irm'],
    timings in seconds), 'irms' (samples, the sun + sky model, and 'maps': for each of
    'lit_to_lit', 'shadow_to_shadow', 'lit_to_shadow', 'shadow_to_lit', its 'ratio' float32
    (bins, bins, 3) target / source per channel on the octahedral square (processing/irm/irm.h;
    NaN where empty), 'count' int32 (bins, bins) samples, 'source' uint8 (bins, bins): 0 empty,
    1 measured, 2 smoothing, 3 model).

Raises:
    relume.InvalidArgumentError with relume's message for invalid options, images, cameras,
    sun directions or meshes.
)doc");
}

}  // namespace relume::python
