// Radiosity and reflectance on numpy arrays (processing/radiosity/): a scene given as arrays
// (triangles with Lambertian materials) and lights given as dicts, split into the patch hierarchy,
// lit directly with ray-cast visibility, solved by hierarchical radiosity, and the iterative
// reflectance estimate of Loscos et al. from per-patch radiance. Units are the library's
// (scene.h): metres, irradiance and radiosity in W m^-2 (or a relative unit, consistently),
// radiance in W m^-2 sr^-1, intensity in W sr^-1; triangles one-sided, counter-clockwise
// seen from the front.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "processing/geometry/ray_caster.h"
#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/radiosity_solver.h"
#include "processing/radiosity/reference_scale.h"
#include "processing/radiosity/reflectance.h"
#include "processing/radiosity/scene.h"
#include "python/bindings.h"
#include "python/convert.h"
#include "python/numpy_mat.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace relume::python {

namespace {

using radiosity::Rgb;

py::dict AsDict(const py::handle& value, const std::string& what) {
  if (!py::isinstance<py::dict>(value)) throw InvalidArgumentError(what + ": expected a dict");
  return py::reinterpret_borrow<py::dict>(value);
}

py::object Get(const py::dict& d, const char* key) {
  return d.contains(key) ? py::reinterpret_borrow<py::object>(d[key]) : py::object(py::none());
}

Eigen::Vector3d VectorOr(const py::dict& d, const char* key, const Eigen::Vector3d& fallback, const std::string& what) {
  const py::object v = Get(d, key);
  return v.is_none() ? fallback : Vector3FromPython(v, what + "['" + key + "']");
}

double NumberOr(const py::dict& d, const char* key, double fallback) {
  const py::object v = Get(d, key);
  return v.is_none() ? fallback : v.cast<double>();
}

// {'positions' (N, 3), 'triangles' (M, 3) int32, 'material' (M,) int32, 'albedo' (K, 3),
//  'emission' (K, 3) or absent}.
radiosity::Mesh SceneFromPython(const py::handle& scene) {
  const py::dict d = AsDict(scene, "scene");
  radiosity::Mesh mesh;
  for (const char* key : {"positions", "triangles", "material", "albedo"}) {
    if (!d.contains(key)) throw InvalidArgumentError(std::string("scene: missing key '") + key + "'");
  }
  for (const Eigen::Vector3d& p : Vectors3dFromArray(d["positions"], "scene['positions']")) {
    mesh.geometry.positions.push_back(p.cast<float>());
  }
  const auto triangles = ContiguousArray<std::int32_t>(py::array::ensure(d["triangles"]), "scene['triangles']");
  if (triangles.ndim() != 2 || triangles.shape(1) != 3) {
    throw InvalidArgumentError("scene['triangles']: expected an (M, 3) int32 array");
  }
  const auto material = ContiguousArray<std::int32_t>(py::array::ensure(d["material"]), "scene['material']");
  if (material.ndim() != 1 || material.shape(0) != triangles.shape(0)) {
    throw InvalidArgumentError("scene['material']: expected an (M,) int32 array, one material index per triangle");
  }
  for (py::ssize_t t = 0; t < triangles.shape(0); ++t) {
    mesh.geometry.triangles.emplace_back(triangles.at(t, 0), triangles.at(t, 1), triangles.at(t, 2));
    mesh.geometry.material.push_back(material.at(t));
  }
  const std::vector<Eigen::Vector3d> albedo = Vectors3dFromArray(d["albedo"], "scene['albedo']");
  std::vector<Eigen::Vector3d> emission(albedo.size(), Eigen::Vector3d::Zero());
  if (!Get(d, "emission").is_none()) emission = Vectors3dFromArray(d["emission"], "scene['emission']");
  if (emission.size() != albedo.size()) {
    throw InvalidArgumentError("scene['emission']: expected one row per material, as scene['albedo']");
  }
  for (std::size_t k = 0; k < albedo.size(); ++k) {
    radiosity::Material m;
    m.name = "material " + std::to_string(k);
    m.albedo = albedo[k];
    m.emitted_radiosity = emission[k];
    mesh.AddMaterial(m);
  }
  std::string why;
  if (!mesh.IsValid(&why)) throw InvalidArgumentError("scene: " + why);
  return mesh;
}

radiosity::Lighting LightingFromPython(const py::handle& lighting, const std::string& what) {
  radiosity::Lighting out;
  if (lighting.is_none()) return out;
  const py::dict d = AsDict(lighting, what);
  for (const auto& [key, value] : d) {
    const std::string k = py::str(key).cast<std::string>();
    if (k != "point_lights" && k != "area_lights" && k != "sun_sky") {
      throw InvalidArgumentError(what + ": unknown key '" + k + "' (point_lights, area_lights, sun_sky)");
    }
  }
  if (d.contains("point_lights")) {
    for (const py::handle& item : d["point_lights"]) {
      const std::string w = what + "['point_lights']";
      const py::dict l = AsDict(item, w);
      radiosity::PointLight p;
      p.position_m = VectorOr(l, "position_m", p.position_m, w);
      p.intensity_w_per_sr = VectorOr(l, "intensity_w_per_sr", p.intensity_w_per_sr, w);
      p.spot_direction = VectorOr(l, "spot_direction", p.spot_direction, w);
      p.cone_half_angle_rad = NumberOr(l, "cone_half_angle_rad", p.cone_half_angle_rad);
      p.falloff_rad = NumberOr(l, "falloff_rad", p.falloff_rad);
      out.point_lights.push_back(p);
    }
  }
  if (d.contains("area_lights")) {
    for (const py::handle& item : d["area_lights"]) {
      const std::string w = what + "['area_lights']";
      const py::dict l = AsDict(item, w);
      radiosity::AreaLight a;
      a.corner_m = VectorOr(l, "corner_m", a.corner_m, w);
      a.edge_u_m = VectorOr(l, "edge_u_m", a.edge_u_m, w);
      a.edge_v_m = VectorOr(l, "edge_v_m", a.edge_v_m, w);
      a.radiance = VectorOr(l, "radiance", a.radiance, w);
      out.area_lights.push_back(a);
    }
  }
  if (d.contains("sun_sky")) {
    for (const py::handle& item : d["sun_sky"]) {
      const std::string w = what + "['sun_sky']";
      const py::dict l = AsDict(item, w);
      radiosity::SunSky s;
      s.sun_dir_in_scene = VectorOr(l, "sun_dir", s.sun_dir_in_scene, w);
      s.sun_irradiance_normal = VectorOr(l, "sun_irradiance_normal", s.sun_irradiance_normal, w);
      s.sky_radiance = VectorOr(l, "sky_radiance", s.sky_radiance, w);
      out.sun_sky.push_back(s);
    }
  }
  std::string why;
  if (!out.IsValid(&why)) throw InvalidArgumentError(what + ": " + why);
  return out;
}

py::array_t<double> RgbToArray(const std::vector<Rgb>& v) {
  return Vectors3dToArray(v);
}

py::array_t<double> DoublesToArray(const std::vector<double>& v) {
  return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

py::dict PatchesToPython(const radiosity::PatchHierarchy& h) {
  const auto n = static_cast<py::ssize_t>(h.LeafCount());
  std::vector<Eigen::Vector3d> centroid, normal;
  py::array_t<double> vertices({n, py::ssize_t{3}, py::ssize_t{3}});
  py::array_t<double> area(n);
  py::array_t<std::int32_t> triangle(n), material(n), level(n);
  auto v = vertices.mutable_unchecked<3>();
  for (int p = 0; p < h.LeafCount(); ++p) {
    const radiosity::Node& node = h.leaf(p);
    centroid.push_back(node.centroid);
    normal.push_back(node.normal);
    const Eigen::Vector3d* corners[3] = {&node.triangle.v0, &node.triangle.v1, &node.triangle.v2};
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c) v(p, k, c) = (*corners[k])[c];
    }
    area.mutable_at(p) = node.area_m2;
    triangle.mutable_at(p) = node.root;
    material.mutable_at(p) = node.material;
    level.mutable_at(p) = node.level;
  }
  return py::dict("centroid"_a = Vectors3dToArray(centroid), "normal"_a = Vectors3dToArray(normal),
                  "vertices"_a = vertices, "area_m2"_a = area, "triangle"_a = triangle, "material"_a = material,
                  "level"_a = level);
}

py::dict SummaryToPython(const radiosity::RadiositySummary& s) {
  return py::dict("termination"_a = radiosity::ToString(s.termination), "converged"_a = s.converged,
                  "reason"_a = s.reason, "iterations"_a = s.iterations, "residual"_a = s.residual,
                  "contraction"_a = s.contraction, "estimated_error"_a = s.estimated_error, "links"_a = s.links,
                  "form_factors"_a = s.form_factors, "rays"_a = s.rays,
                  "link_budget_exhausted"_a = s.link_budget_exhausted, "power_in"_a = s.power_in,
                  "power_absorbed"_a = s.power_absorbed, "power_escaped"_a = s.power_escaped,
                  "balance_error"_a = s.balance_error, "refine_time_s"_a = s.refine_time_s,
                  "solve_time_s"_a = s.solve_time_s, "patches"_a = s.patches, "brief"_a = s.BriefReport());
}

radiosity::HierarchyOptions HierarchyOptionsFrom(double max_patch_edge_m, int max_depth) {
  radiosity::HierarchyOptions o;
  o.max_patch_edge_m = max_patch_edge_m;
  o.max_depth = max_depth;
  return o;
}

radiosity::RadiosityOptions SolverOptionsFrom(bool hierarchical, double bf_epsilon, int rays_per_form_factor,
                                              int refinement_passes, double residual_tolerance, int max_iterations,
                                              long long max_links) {
  radiosity::RadiosityOptions o;
  o.hierarchical = hierarchical;
  o.bf_epsilon = bf_epsilon;
  o.rays_per_form_factor = rays_per_form_factor;
  o.refinement_passes = refinement_passes;
  o.residual_tolerance = residual_tolerance;
  o.max_iterations = max_iterations;
  o.max_links = max_links;
  return o;
}

radiosity::DirectLightOptions DirectOptionsFrom(int samples_per_patch, int sky_directions) {
  radiosity::DirectLightOptions o;
  o.samples_per_patch = samples_per_patch;
  o.sky_directions = sky_directions;
  return o;
}

py::dict SolveRadiosity(const py::object& scene, const py::object& lighting, const py::object& albedo,
                        double max_patch_edge_m, int max_depth, bool hierarchical, double bf_epsilon,
                        int rays_per_form_factor, int refinement_passes, double residual_tolerance, int max_iterations,
                        long long max_links, int samples_per_patch, int sky_directions) {
  const radiosity::HierarchyOptions hierarchy_options = HierarchyOptionsFrom(max_patch_edge_m, max_depth);
  ThrowIfInvalid(hierarchy_options, "solve_radiosity");
  const radiosity::RadiosityOptions solver_options = SolverOptionsFrom(
      hierarchical, bf_epsilon, rays_per_form_factor, refinement_passes, residual_tolerance, max_iterations, max_links);
  ThrowIfInvalid(solver_options, "solve_radiosity");
  const radiosity::DirectLightOptions direct_options = DirectOptionsFrom(samples_per_patch, sky_directions);
  ThrowIfInvalid(direct_options, "solve_radiosity");
  const radiosity::Mesh mesh = SceneFromPython(scene);
  const radiosity::Lighting lights = LightingFromPython(lighting, "lighting");
  const std::vector<Rgb> albedo_override = albedo.is_none() ? std::vector<Rgb>() : Vectors3dFromArray(albedo, "albedo");
  std::optional<radiosity::PatchHierarchy> h;
  std::vector<Rgb> patch_albedo;
  radiosity::DirectLight direct;
  radiosity::RadiositySolution solution;
  radiosity::RadiositySummary summary;
  {
    py::gil_scoped_release release;
    h.emplace(mesh, hierarchy_options);
    const RayCaster caster(mesh.geometry);
    patch_albedo = albedo_override.empty() ? h->LeafAlbedo() : albedo_override;
    if (patch_albedo.size() != static_cast<std::size_t>(h->LeafCount())) {
      throw InvalidArgumentError("solve_radiosity: albedo has " + std::to_string(patch_albedo.size()) +
                                 " rows, the scene has " + std::to_string(h->LeafCount()) +
                                 " patches at this max_patch_edge_m (radiosity_patches lists them)");
    }
    direct = radiosity::ComputeDirectLight(*h, caster, lights, direct_options);
    radiosity::RadiositySolver solver(*h, caster, solver_options);
    summary = solver.Solve(patch_albedo, direct.irradiance, h->LeafEmission(), &solution);
  }
  return py::dict("patches"_a = PatchesToPython(*h), "radiosity"_a = RgbToArray(solution.radiosity),
                  "direct_irradiance"_a = RgbToArray(direct.irradiance),
                  "visible_fraction"_a = DoublesToArray(direct.visible_fraction),
                  "indirect_irradiance"_a = RgbToArray(solution.indirect_irradiance),
                  "form_factor_sum"_a = DoublesToArray(solution.form_factor_sum), "albedo"_a = RgbToArray(patch_albedo),
                  "summary"_a = SummaryToPython(summary));
}

py::dict Patches(const py::object& scene, double max_patch_edge_m, int max_depth) {
  const radiosity::HierarchyOptions options = HierarchyOptionsFrom(max_patch_edge_m, max_depth);
  ThrowIfInvalid(options, "radiosity_patches");
  const radiosity::PatchHierarchy h(SceneFromPython(scene), options);
  return PatchesToPython(h);
}

// One entry of estimate_reflectance's `references`: a patch of known albedo, its radiance in
// observation 0's units and, optionally, the surface points its pixels saw (default: its centroid).
struct ReferenceInput {
  int patch = -1;
  Rgb albedo = Rgb::Zero();
  Rgb radiance = Rgb::Zero();
  std::vector<Eigen::Vector3f> points;
};

std::vector<ReferenceInput> ReferencesFromPython(const py::object& references) {
  std::vector<ReferenceInput> out;
  const py::list list = py::cast<py::list>(references);
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string what = "references[" + std::to_string(i) + "]";
    const py::dict d = AsDict(list[i], what);
    for (const char* key : {"patch", "albedo", "radiance"}) {
      if (!d.contains(key)) throw InvalidArgumentError(what + ": missing key '" + key + "'");
    }
    ReferenceInput r;
    r.patch = py::cast<int>(d["patch"]);
    r.albedo = Vector3FromPython(d["albedo"], what + "['albedo']");
    r.radiance = Vector3FromPython(d["radiance"], what + "['radiance']");
    if (!Get(d, "points").is_none()) {
      for (const Eigen::Vector3d& p : Vectors3dFromArray(d["points"], what + "['points']")) {
        r.points.push_back(p.cast<float>());
      }
    }
    out.push_back(std::move(r));
  }
  return out;
}

std::vector<radiosity::ReferencePatch> ReferencePatches(const radiosity::PatchHierarchy& h,
                                                        const std::vector<ReferenceInput>& inputs) {
  std::vector<radiosity::ReferencePatch> out;
  for (const ReferenceInput& in : inputs) {
    radiosity::ReferencePatch r{in.patch, in.albedo, in.radiance, in.points};
    if (r.points.empty() && in.patch >= 0 && in.patch < h.LeafCount()) {
      r.points.push_back(h.leaf(in.patch).centroid.cast<float>());
    }
    out.push_back(std::move(r));
  }
  return out;
}

py::dict EstimateReflectance(const py::object& scene, const py::list& observations, double max_patch_edge_m,
                             int max_depth, int max_iterations, double albedo_tolerance, bool fit_image_scales,
                             double unlit_weight, double boundary_radius_m, int boundary_samples,
                             double indirect_skip_tolerance, double prior_albedo, bool unseen_from_material,
                             bool unseen_from_scene_mean, bool indirect_from_observed, int samples_per_patch,
                             int sky_directions, bool hierarchical, double bf_epsilon, int rays_per_form_factor,
                             int refinement_passes, double residual_tolerance, int solver_max_iterations,
                             long long max_links, const py::object& references) {
  const radiosity::HierarchyOptions hierarchy_options = HierarchyOptionsFrom(max_patch_edge_m, max_depth);
  ThrowIfInvalid(hierarchy_options, "estimate_reflectance");
  radiosity::ReflectanceOptions options;
  options.max_iterations = max_iterations;
  options.albedo_tolerance = albedo_tolerance;
  options.fit_image_scales = fit_image_scales;
  options.unlit_weight = unlit_weight;
  options.boundary_radius_m = boundary_radius_m;
  options.boundary_samples = boundary_samples;
  options.indirect_skip_tolerance = indirect_skip_tolerance;
  options.prior_albedo = prior_albedo;
  options.unseen_from_material = unseen_from_material;
  options.unseen_from_scene_mean = unseen_from_scene_mean;
  options.indirect_from_observed = indirect_from_observed;
  options.direct = DirectOptionsFrom(samples_per_patch, sky_directions);
  options.radiosity = SolverOptionsFrom(hierarchical, bf_epsilon, rays_per_form_factor, refinement_passes,
                                        residual_tolerance, solver_max_iterations, max_links);
  ThrowIfInvalid(options, "estimate_reflectance");
  const radiosity::Mesh mesh = SceneFromPython(scene);
  std::vector<radiosity::RadianceObservation> observed;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const std::string what = "observations[" + std::to_string(i) + "]";
    const py::dict d = AsDict(observations[i], what);
    if (!d.contains("radiance")) throw InvalidArgumentError(what + ": missing key 'radiance'");
    radiosity::RadianceObservation o;
    o.lighting = LightingFromPython(Get(d, "lighting"), what + "['lighting']");
    o.radiance = Vectors3dFromArray(d["radiance"], what + "['radiance']");
    if (!Get(d, "camera_position_m").is_none()) {
      o.camera_position_m = Vector3FromPython(d["camera_position_m"], what + "['camera_position_m']");
    }
    observed.push_back(std::move(o));
  }
  std::vector<ReferenceInput> reference_inputs;
  if (!references.is_none()) reference_inputs = ReferencesFromPython(references);
  radiosity::ReflectanceResult r;
  std::optional<radiosity::ReferenceScaleResult> scale;
  std::optional<radiosity::PatchHierarchy> h;
  {
    py::gil_scoped_release release;
    h.emplace(mesh, hierarchy_options);
    const RayCaster caster(mesh.geometry);
    if (!references.is_none()) {
      // The absolute scale from the references first (reference_scale.h), then the albedo at it.
      scale = radiosity::EstimateReferenceScale(*h, caster, observed, ReferencePatches(*h, reference_inputs), options,
                                                radiosity::ReferenceScaleOptions());
      for (radiosity::RadianceObservation& o : observed) {
        for (Rgb& v : o.radiance) v *= scale->scale;
      }
    }
    r = radiosity::EstimateReflectance(*h, caster, observed, options);
  }
  py::array_t<bool> estimated(static_cast<py::ssize_t>(r.estimated.size()));
  for (std::size_t p = 0; p < r.estimated.size(); ++p)
    estimated.mutable_at(static_cast<py::ssize_t>(p)) = r.estimated[p];
  py::list solves;
  for (const radiosity::RadiositySummary& s : r.last_solves) solves.append(SummaryToPython(s));
  const radiosity::IndirectShareEstimate& e = r.indirect;
  return py::dict(
      "patches"_a = PatchesToPython(*h), "albedo"_a = RgbToArray(r.albedo),
      "initial_albedo"_a = RgbToArray(r.initial_albedo), "confidence"_a = DoublesToArray(r.confidence),
      "estimated"_a = estimated, "image_scale"_a = DoublesToArray(r.image_scale), "scale_samples"_a = r.scale_samples,
      "iterations"_a = r.iterations, "converged"_a = r.converged, "reason"_a = r.reason,
      "max_change"_a = DoublesToArray(r.max_change), "mean_change"_a = DoublesToArray(r.mean_change),
      "clamped"_a = r.clamped, "radiosity_skipped"_a = r.radiosity_skipped,
      "indirect"_a = py::dict("first_bounce_ratio"_a = e.first_bounce_ratio, "series_ratio"_a = e.series_ratio,
                              "indirect_share"_a = e.indirect_share, "mean_enclosure"_a = e.mean_enclosure,
                              "skip"_a = e.skip, "reason"_a = e.reason),
      "last_solves"_a = solves, "time_s"_a = r.time_s,
      "reference_scale"_a =
          scale ? py::object(py::dict("scale"_a = scale->scale, "direct_only_scale"_a = scale->direct_only_scale,
                                      "relative_spread"_a = scale->relative_spread, "samples"_a = scale->samples,
                                      "patches"_a = scale->patches, "indirect_share"_a = scale->indirect_share,
                                      "history"_a = DoublesToArray(scale->history), "solves"_a = scale->solves,
                                      "converged"_a = scale->converged, "reason"_a = scale->reason))
                : py::object(py::none()));
}

constexpr const char* kSceneDoc =
    R"doc(    scene: dict {'positions' (N, 3) metres, 'triangles' (M, 3) int32 (counter-clockwise seen
        from the front: one-sided), 'material' (M,) int32 index per triangle, 'albedo' (K, 3)
        per material in [0, 1], 'emission' (K, 3) self-emitted radiosity, W m^-2, or absent}.
    max_patch_edge_m, max_depth: triangles are split (quadtrees) until no patch edge exceeds
        max_patch_edge_m metres, at most max_depth levels; the same scene and values always give
        the same patches (radiosity_patches lists them).
)doc";

constexpr const char* kLightingDoc =
    R"doc(    lighting: dict with any of 'point_lights' [{'position_m', 'intensity_w_per_sr' (RGB),
        'spot_direction' (zero: isotropic), 'cone_half_angle_rad', 'falloff_rad'}],
        'area_lights' [{'corner_m', 'edge_u_m', 'edge_v_m', 'radiance' (W m^-2 sr^-1), emitting
        to the side of edge_u x edge_v}], 'sun_sky' [{'sun_dir' (unit, toward the sun),
        'sun_irradiance_normal' (W m^-2), 'sky_radiance' (uniform over z > 0)}]; None: no lights.
)doc";

constexpr const char* kPatchesDoc =
    R"doc('patches' (dict of per-patch arrays: centroid, normal, vertices (P, 3, 3), area_m2,
    triangle (the scene triangle it lies on), material, level))doc";

}  // namespace

void BindRadiosity(py::module_& m) {
  const radiosity::HierarchyOptions h;
  const radiosity::RadiosityOptions s;
  const radiosity::DirectLightOptions d;
  m.def("radiosity_patches", &Patches, "scene"_a, py::kw_only(), "max_patch_edge_m"_a = h.max_patch_edge_m,
        "max_depth"_a = h.max_depth,
        (std::string("The radiosity patches of a scene (processing/radiosity/hierarchy.h), the rows of every per-patch "
                     "array of solve_radiosity and estimate_reflectance.\n\nArgs:\n") +
         kSceneDoc + "\nReturns:\n    " + kPatchesDoc + ".\n")
            .c_str());
  m.def("solve_radiosity", &SolveRadiosity, "scene"_a, "lighting"_a = py::none(), py::kw_only(),
        "albedo"_a = py::none(), "max_patch_edge_m"_a = h.max_patch_edge_m, "max_depth"_a = h.max_depth,
        "hierarchical"_a = s.hierarchical, "bf_epsilon"_a = s.bf_epsilon,
        "rays_per_form_factor"_a = s.rays_per_form_factor, "refinement_passes"_a = s.refinement_passes,
        "residual_tolerance"_a = s.residual_tolerance, "max_iterations"_a = s.max_iterations,
        "max_links"_a = s.max_links, "samples_per_patch"_a = d.samples_per_patch, "sky_directions"_a = d.sky_directions,
        (std::string(R"doc(Direct light and hierarchical radiosity of a Lambertian scene (processing/radiosity/).

Per patch i and channel: B_i = emission_i + albedo_i (E_direct_i + sum_j F_ij B_j); direct
light with ray-cast visibility (direct_light.h), then the library's RadiositySolver (Hanrahan,
Salzman & Aupperle links, block Gauss-Seidel). The GIL is released while it runs.

Args:
)doc") + kSceneDoc +
         kLightingDoc +
         R"doc(    albedo: (P, 3) per-patch albedo instead of the materials' (e.g. estimate_reflectance's).
    hierarchical, bf_epsilon, rays_per_form_factor, refinement_passes: link refinement (the
        BF oracle's threshold relative to the mean radiosity; visibility rays per link).
    residual_tolerance, max_iterations, max_links: when the solve stops (relative residual),
        and the memory guard on links.
    samples_per_patch, sky_directions: direct light: points per patch (one shadow ray each
        per light) and cosine-weighted sky directions per patch.

Returns:
    dict: )doc" +
         kPatchesDoc +
         R"doc(, 'radiosity' (P, 3) W m^-2 (a Lambertian
    patch's radiance is B / pi), 'direct_irradiance' (P, 3), 'visible_fraction' (P,),
    'indirect_irradiance' (P, 3) (sum_j F_ij B_j), 'form_factor_sum' (P,) (1 in a closed
    room), 'albedo' (P, 3) used, 'summary' (termination, converged, reason, iterations,
    residual, links, power_in / absorbed / escaped, balance_error, brief, ...).

Raises:
    relume.InvalidArgumentError with relume's message for an invalid scene, lighting or options.
)doc")
            .c_str());
  const radiosity::ReflectanceOptions r;
  m.def("estimate_reflectance", &EstimateReflectance, "scene"_a, "observations"_a, py::kw_only(),
        "max_patch_edge_m"_a = h.max_patch_edge_m, "max_depth"_a = h.max_depth, "max_iterations"_a = r.max_iterations,
        "albedo_tolerance"_a = r.albedo_tolerance, "fit_image_scales"_a = r.fit_image_scales,
        "unlit_weight"_a = r.unlit_weight, "boundary_radius_m"_a = r.boundary_radius_m,
        "boundary_samples"_a = r.boundary_samples, "indirect_skip_tolerance"_a = r.indirect_skip_tolerance,
        "prior_albedo"_a = r.prior_albedo, "unseen_from_material"_a = r.unseen_from_material,
        "unseen_from_scene_mean"_a = r.unseen_from_scene_mean, "indirect_from_observed"_a = r.indirect_from_observed,
        "samples_per_patch"_a = r.direct.samples_per_patch, "sky_directions"_a = r.direct.sky_directions,
        "hierarchical"_a = r.radiosity.hierarchical, "bf_epsilon"_a = r.radiosity.bf_epsilon,
        "rays_per_form_factor"_a = r.radiosity.rays_per_form_factor,
        "refinement_passes"_a = r.radiosity.refinement_passes, "residual_tolerance"_a = r.radiosity.residual_tolerance,
        "solver_max_iterations"_a = r.radiosity.max_iterations, "max_links"_a = r.radiosity.max_links,
        "references"_a = py::none(),
        (std::string(R"doc(Diffuse reflectance (albedo) per patch from radiance seen under known lights (Loscos et al.).

Per image s and patch i: albedo = pi a_s L_is / (E_direct_is + I_is), the indirect light I from
radiosity, iterated until no albedo changes by more than albedo_tolerance, the images combined
by confidence (processing/radiosity/reflectance.h says how).

Args:
)doc") + kSceneDoc +
         R"doc(        (the materials' albedo is not used, only their grouping for unseen patches.)
    observations: list of dicts, one per image: {'radiance' (P, 3) per patch, linear, NaN where
        the image does not see the patch; 'lighting' (as solve_radiosity's) the lights on;
        'camera_position_m' (3,) or absent (enables the viewing-angle and occlusion weights)}.
    max_iterations, albedo_tolerance: radiosity iterations after the ambient estimate, and
        the stop.
    fit_image_scales: fit each image's radiance scale (EV-only cameras; image 0 the reference).
    unlit_weight, boundary_radius_m, boundary_samples: confidence of patches in shadow and
        near shadow or occlusion boundaries (metres, rays; 0 samples: off).
    indirect_skip_tolerance: > 0: skip radiosity when the indirect share is below it.
    prior_albedo, unseen_from_material, unseen_from_scene_mean: albedo of unseen patches.
    indirect_from_observed: gather indirect light from the observed radiosity where seen.
    samples_per_patch, sky_directions: direct light, as solve_radiosity's.
    hierarchical ... max_links: the radiosity solver's options (solver_max_iterations is its
        max_iterations).
    references: None, or patches of known albedo (a chart) that make relative radiance
        absolute: a list of dicts {'patch' (index), 'albedo' (3,), 'radiance' (3,) in
        observation 0's units, 'points' (K, 3) where its pixels saw it (default: its centroid)}.
        The scale k of pi k L = albedo (E_direct + E_indirect(k)) is found first
        (processing/radiosity/reference_scale.h) and every observation multiplied by it.

Returns:
    dict: )doc" +
         kPatchesDoc +
         R"doc(, 'albedo' (P, 3) in [0, 1], 'initial_albedo'
    (iteration 0), 'confidence' (P,), 'estimated' bool (P,) (False: prior), 'image_scale',
    'iterations', 'converged', 'reason', 'max_change', 'mean_change', 'clamped',
    'radiosity_skipped', 'indirect' (the indirect-share estimate), 'last_solves', 'time_s',
    'reference_scale' (None, or: 'scale', 'direct_only_scale', 'relative_spread', 'samples',
    'patches', 'indirect_share', 'history', 'solves', 'converged', 'reason').
)doc")
            .c_str());
}

}  // namespace relume::python
