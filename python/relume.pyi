# Type stubs for the relume module (python/*_bindings.cc; docs/python.md). Written by hand with
# numpy types where the bindings take arrays; python/tests/test_stubs.py checks that every
# function and Session member of the module is here with the same parameters, in order, and the
# same keyword-only marks and defaults. help(relume.NAME) has each argument's meaning and units.
import os
from typing import Any, Literal, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

_Array = npt.NDArray[Any]
_F32 = npt.NDArray[np.float32]
_F64 = npt.NDArray[np.float64]
_U8 = npt.NDArray[np.uint8]
_Path = Union[str, os.PathLike[str]]
_Vec3 = Union[Sequence[float], npt.ArrayLike]
_Mask = Optional[npt.NDArray[Union[np.bool_, np.uint8]]]

class Error(Exception): ...
class InvalidArgumentError(Error, ValueError): ...
class ConfigError(Error, ValueError):
    file: str
    line: int
    key: str
class IoError(Error, OSError):
    path: str
    reason: str

# Sun
def sun_positions(unix_seconds: npt.ArrayLike, lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike,
                  height_m: npt.ArrayLike = 0.0, delta_t_s: Optional[npt.ArrayLike] = None,
                  pressure_hpa: npt.ArrayLike = 1013.25, temperature_c: npt.ArrayLike = 15.0,
                  dut1_s: npt.ArrayLike = 0.0, threads: int = 0) -> tuple[Any, Any]: ...
def enu_direction(azimuth_deg: float, elevation_deg: float) -> _F64: ...

# HDR
def recover_response(frames: Sequence[_U8], exposure_times_s: Sequence[float], *, method: str = 'debevec',
                     sample_count: int = 300, smoothing_lambda: float = 60.0, smoothness: str = 'log-code',
                     black_margin: int = 2, saturation_margin: int = 2,
                     seed: int = 1) -> tuple[_F64, dict[str, Any]]: ...
def merge_hdr(frames: Sequence[_Array], exposure_times_s: Sequence[float], response: Union[_F64, Literal['linear']], *,
              black_margin: int = 2, saturation_margin: int = 2, weight_by_exposure: bool = True, threads: int = 0,
              full_output: bool = False, black_level: Optional[int] = None, white_level: Optional[int] = None,
              bits_per_sample: Optional[int] = None) -> Any: ...
def load_radiance_exr(path: _Path) -> _F32: ...

# Sessions and pipelines
class Session:
    def __init__(self, path: _Path) -> None: ...
    @property
    def path(self) -> str: ...
    @property
    def info(self) -> dict[str, Any]: ...
    @property
    def frames(self) -> list[dict[str, Any]]: ...
    @property
    def devices(self) -> list[dict[str, Any]]: ...
    @property
    def brackets(self) -> list[dict[str, Any]]: ...
    @property
    def calibrations(self) -> list[dict[str, Any]]: ...
    @property
    def events(self) -> list[dict[str, Any]]: ...
    def load_image(self, frame_id: int, *, verify_checksum: bool = True) -> _Array: ...
    def load_depth(self, frame_id: int, *, verify_checksum: bool = True) -> _F32: ...
    def camera(self, device_id: str) -> dict[str, Any]: ...
    def linear_radiance(self, frames: Union[str, int], *, use_calibrations: bool = True, merge_black_margin: int = 2,
                        merge_saturation_margin: int = 2, response_samples: int = 300, response_lambda: float = 60.0,
                        response_smoothness: str = 'log-code') -> dict[str, Any]: ...
    def scene_mesh(self, *, spacing_m: float = 0.5, sphere_segments: int = 48) -> dict[str, Any]: ...

def process(session_dir: _Path, pipeline: str = 'all', *, out_dir: Optional[_Path] = None, source: Any = None,
            target: Any = None, mesh: Optional[_Path] = None, target_light: Any = None,
            settings: Optional[dict[str, Any]] = None, explain: bool = False,
            force: bool = False) -> dict[str, Any]: ...
def pipelines() -> list[dict[str, Any]]: ...

# IRM
def irm_relight(mesh: dict[str, Any], source_radiance: _F32, target_radiance: _F32, source_camera: dict[str, Any],
                target_camera: dict[str, Any], source_sun_dir: _Vec3, target_sun_dir: _Vec3, *,
                source_mask: _Mask = None, target_mask: _Mask = None, bins: int = 32, lit_threshold: float = 0.99,
                shadow_threshold: float = 0.01, min_samples_per_bin: int = 2, trim_fraction: float = 0.2,
                min_source_radiance: float = 1e-06, fill: str = 'sun_sky_model', model_correction: bool = True,
                single_map_without_shadow: bool = True, smoothing_sigma_rad: float = 0.2, sun_samples: int = 16,
                sky_samples: int = 144, sky_gradient: bool = True, sun_angular_radius_rad: float = 0.0046513,
                penumbra: bool = True, exact_shadow_edges: bool = True, indirect: bool = True,
                indirect_samples: int = 144, indirect_passes: int = 2, threads: int = 0) -> dict[str, Any]: ...

# Depth and normals
def bilateral_filter_depth(depth_m: _F32, *, radius_px: int = 1, spatial_sigma_px: float = 1.0,
                           range_sigma_at_1m_m: float = 0.005, edge_cut_sigmas: float = 3.0) -> _F32: ...
def temporal_filter_depth(current_m: _F32, previous_m: Optional[_F32], *, weight: float = 1.0,
                          max_difference_sigmas: float = 3.0,
                          range_sigma_at_1m_m: float = 0.005) -> tuple[_F32, int]: ...
def estimate_depth_noise(depth_m: _F32, edge_jump_fraction: float = 0.02) -> dict[str, Any]: ...
def estimate_normals(depth_m: _F32, intrinsics: dict[str, Any], *, window_radius_px: int = 3,
                     depth_change_ratio: float = 0.02, min_valid_fraction: float = 0.5,
                     plane_step_tolerance: float = 1e-4, refine_creases: bool = True,
                     refine_creases_below_noise_at_1m_m: float = 5e-5, min_window_radius_px: int = 1,
                     neighbour_boxes_on_noisy_depth: bool = True, jet_radius_px: int = 2,
                     jet_max_residual: float = 0.01, depth_noisy: bool = False) -> dict[str, Any]: ...
def vertex_map(depth_m: _F32, intrinsics: dict[str, Any]) -> _F32: ...

# SH lighting
def fit_sh(radiance: _F32, normals: _F32, *, albedo: Optional[_F32] = None, mask: _Mask = None, max_order: int = 2,
           max_condition_number: float = 150.0, min_solid_angle_order2_sr: float = 1.5,
           min_observations_per_coefficient: int = 4) -> tuple[_F64, dict[str, Any]]: ...
def fit_sh_unknown_albedo(radiance: _F32, normals: _F32, labels: npt.NDArray[np.int32], *, mask: _Mask = None,
                          max_iterations: int = 200, tolerance: float = 1e-07, min_observations_per_segment: int = 10,
                          reference_segment: int = -1, reference_albedo: _Vec3 = [0.5, 0.5, 0.5], max_order: int = 2,
                          max_condition_number: float = 150.0, min_solid_angle_order2_sr: float = 1.5,
                          min_observations_per_coefficient: int = 4) -> tuple[_F64, _F64, dict[str, Any]]: ...
def segment_by_color(radiance: _F32, *, mask: _Mask = None, normals: Optional[_F32] = None, segment_count: int = 4,
                     use_normals: bool = False, normal_weight: float = 0.3, max_cluster_pixels: int = 4000,
                     attempts: int = 3, max_iterations: int = 30,
                     seed: int = 1) -> tuple[npt.NDArray[np.int32], list[int], _F64]: ...
def sh_irradiance(light: npt.ArrayLike, normals: npt.ArrayLike) -> _F64: ...
def sh_radiance(light: npt.ArrayLike, directions: npt.ArrayLike) -> _F64: ...
def relight_sh(source: _F32, normals: _F32, source_light: npt.ArrayLike, target_light: npt.ArrayLike, *,
               mask: _Mask = None,
               min_irradiance_fraction: float = 0.1, ratio_radius_px: int = 3, ratio_spatial_sigma_px: float = 1.5,
               ratio_range_sigma: float = 0.015,
               max_albedo_deviation: float = 2.0) -> tuple[_F32, npt.NDArray[np.bool_], dict[str, Any]]: ...
def fit_nonnegative_light(radiance: _F32, normals: _F32, *, albedo: Optional[_F32] = None, mask: _Mask = None,
                          direction_count: int = 512, min_observations: int = 50, ridge: float = 1e-07,
                          outlier_rounds: int = 1, outlier_mads: float = 3.0,
                          min_outlier_residual: float = 0.1) -> tuple[tuple[_F64, _F64], dict[str, Any]]: ...
def relight_nonnegative(source: _F32, normals: _F32, source_light: tuple[npt.ArrayLike, npt.ArrayLike],
                        target_light: tuple[npt.ArrayLike, npt.ArrayLike], *, mask: _Mask = None,
                        min_irradiance_fraction: float = 0.1, ratio_radius_px: int = 3,
                        ratio_spatial_sigma_px: float = 1.5,
                        ratio_range_sigma: float = 0.015,
               max_albedo_deviation: float = 2.0) -> tuple[_F32, npt.NDArray[np.bool_], dict[str, Any]]: ...

# ColorChecker
def load_colorchecker_reference(path: _Path) -> dict[str, Any]: ...
def detect_colorchecker(preview: _U8, reference: _Path, *, detector: str = 'auto',
                        min_patch_side_px: int = 6) -> dict[str, Any]: ...
def chart_from_corners(corners: npt.ArrayLike, preview: _U8, reference: _Path) -> dict[str, Any]: ...
def sample_patches(values: _F32, corners: npt.ArrayLike, *, clipped: _Mask = None, inner_fraction: float = 0.5,
                   samples_per_side: int = 12, max_spread: float = 0.08) -> dict[str, Any]: ...
def fit_colorchecker(measured: npt.ArrayLike, reference: _Path, *, status: Optional[Sequence[str]] = None,
                     fit_gain: bool = True, fit_matrix: bool = True, white_preserving: bool = True,
                     ridge: float = 0.0001, max_condition: float = 100.0,
                     max_mean_delta_e: float = 5.0) -> dict[str, Any]: ...
def apply_color_profile(radiance: _F32, profile: Union[_Path, dict[str, Any]]) -> _F32: ...
def preview_linear(values: _F32) -> _U8: ...
def delta_e_2000(lab_a: npt.ArrayLike, lab_b: npt.ArrayLike) -> _F64: ...

# Radiosity and reflectance
def radiosity_patches(scene: dict[str, Any], *, max_patch_edge_m: float = 0.25,
                      max_depth: int = 12) -> dict[str, Any]: ...
def solve_radiosity(scene: dict[str, Any], lighting: Optional[dict[str, Any]] = None, *,
                    albedo: Optional[npt.ArrayLike] = None, max_patch_edge_m: float = 0.25, max_depth: int = 12,
                    hierarchical: bool = True, bf_epsilon: float = 0.002, rays_per_form_factor: int = 4,
                    refinement_passes: int = 2, residual_tolerance: float = 0.01, max_iterations: int = 500,
                    max_links: int = 50000000, samples_per_patch: int = 4,
                    sky_directions: int = 32) -> dict[str, Any]: ...
def estimate_reflectance(scene: dict[str, Any], observations: list[dict[str, Any]], *, max_patch_edge_m: float = 0.25,
                         max_depth: int = 12, max_iterations: int = 6, albedo_tolerance: float = 0.002,
                         fit_image_scales: bool = False, unlit_weight: float = 0.05, boundary_radius_m: float = 0.1,
                         boundary_samples: int = 8, indirect_skip_tolerance: float = 0.0, prior_albedo: float = 0.5,
                         unseen_from_material: bool = True, unseen_from_scene_mean: bool = False,
                         indirect_from_observed: bool = True, samples_per_patch: int = 4, sky_directions: int = 32,
                         hierarchical: bool = True, bf_epsilon: float = 0.002, rays_per_form_factor: int = 4,
                         refinement_passes: int = 2, residual_tolerance: float = 0.01, solver_max_iterations: int = 500,
                         max_links: int = 50000000, references: list[dict[str, Any]] | None = None) -> dict[str, Any]: ...
