// The pieces of the `relume` Python module (module.cc assembles them). Each Bind* adds one part
// of the library's API to the module; docs/python.md describes what Python sees.
#pragma once

#include <pybind11/pybind11.h>

namespace relume::python {

// relume.Error and its subclasses, and the translation of relume's C++ exceptions into them.
void BindErrors(pybind11::module_& m);
// relume.sun_positions.
void BindSun(pybind11::module_& m);
// relume.recover_response, relume.merge_hdr.
void BindHdr(pybind11::module_& m);
// relume.Session.
void BindSession(pybind11::module_& m);
// relume.process, relume.pipelines.
void BindProcess(pybind11::module_& m);
// relume.enu_direction, relume.irm_relight.
void BindIrm(pybind11::module_& m);
// relume.bilateral_filter_depth, temporal_filter_depth, estimate_depth_noise, estimate_normals,
// vertex_map.
void BindDepth(pybind11::module_& m);
// relume.fit_sh, fit_sh_unknown_albedo, segment_by_color, sh_irradiance, sh_radiance, relight_sh.
void BindSh(pybind11::module_& m);
// relume.load_colorchecker_reference, detect_colorchecker, chart_from_corners, sample_patches,
// fit_colorchecker, apply_color_profile, preview_linear, delta_e_2000.
void BindColor(pybind11::module_& m);
// relume.radiosity_patches, solve_radiosity, estimate_reflectance.
void BindRadiosity(pybind11::module_& m);

// A JSON value as the equivalent Python object (dict, list, str, float, int, bool, None).
pybind11::object JsonToPython(const std::string& json_text);

}  // namespace relume::python
