"""Radiosity and reflectance from Python against analytic cases: a closed box glowing uniformly
(B = E / (1 - albedo)), a floor under a point lamp (E = I h / r^3, nothing bounces), and albedo
recovered from the radiance a forward solve gives."""
import numpy as np
import pytest

import relume


def box(lo, hi, inward):
    """An axis-aligned box as 12 triangles, counter-clockwise seen from outside (or from inside
    when `inward`: a room)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    quads = [[(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)],  # bottom
             [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # top
             [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # y = y0
             [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # y = y1
             [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],  # x = x0
             [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)]]  # x = x1
    positions, triangles = [], []
    for quad in quads:
        quad = quad[::-1] if inward else quad
        base = len(positions)
        positions += quad
        triangles += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return np.array(positions, float), np.array(triangles, np.int32)


def test_a_closed_glowing_box_reaches_emission_over_one_minus_albedo():
    positions, triangles = box((0, 0, 0), (1, 1, 1), inward=True)
    albedo = np.array([0.5, 0.6, 0.7])
    scene = {"positions": positions, "triangles": triangles, "material": np.zeros(12, np.int32), "albedo": [albedo],
             "emission": [[1.0, 1.0, 1.0]]}
    result = relume.solve_radiosity(scene, residual_tolerance=1e-4)
    summary = result["summary"]
    assert summary["converged"] and summary["termination"] == "converged" and abs(summary["balance_error"]) < 1e-3
    patches = result["patches"]
    area = patches["area_m2"]
    assert area.sum() == pytest.approx(6.0, rel=1e-12) and len(area) == summary["patches"]
    assert (np.linalg.norm(patches["vertices"] - patches["centroid"][:, None, :], axis=-1) <= 0.25).all()
    expected = 1.0 / (1.0 - albedo)
    radiosity = result["radiosity"]
    assert np.allclose(area @ radiosity / area.sum(), expected, rtol=5e-3)  # energy: exact up to the residual
    assert np.abs(radiosity / expected - 1).max() < 0.1  # per patch: form factors from 4 rays per link
    assert np.average(result["form_factor_sum"], weights=area) == pytest.approx(1.0, abs=0.01)
    assert np.allclose(result["albedo"], albedo)


def test_a_floor_under_a_point_lamp_gets_inverse_square_cosine_light():
    floor = {"positions": np.array([(0, 0, 0), (4, 0, 0), (4, 4, 0), (0, 4, 0)], float),
             "triangles": np.array([(0, 1, 2), (0, 2, 3)], np.int32), "material": np.zeros(2, np.int32),
             "albedo": [[0.5, 0.4, 0.3]]}
    lamp = {"point_lights": [{"position_m": (2.0, 2.0, 1.0), "intensity_w_per_sr": (10.0, 10.0, 10.0)}]}
    result = relume.solve_radiosity(floor, lamp, max_patch_edge_m=0.1)
    to_lamp = np.array([2.0, 2.0, 1.0]) - result["patches"]["centroid"]
    irradiance = 10.0 * to_lamp[:, 2] / np.linalg.norm(to_lamp, axis=1) ** 3
    assert np.abs(result["direct_irradiance"][:, 0] / irradiance - 1).max() < 0.005
    assert np.allclose(result["radiosity"], result["direct_irradiance"] * [0.5, 0.4, 0.3])
    assert not result["indirect_irradiance"].any()  # a plane sees nothing of itself
    assert np.all(result["visible_fraction"] == 1.0)
    assert relume.radiosity_patches(floor, max_patch_edge_m=0.1)["area_m2"].shape == result["patches"]["area_m2"].shape
    with pytest.raises(relume.InvalidArgumentError, match="solve_radiosity: "):
        relume.solve_radiosity(floor, lamp, max_patch_edge_m=0.0)
    with pytest.raises(relume.InvalidArgumentError, match="point light: .*intensity >= 0"):
        relume.solve_radiosity(floor, {"point_lights": [{"intensity_w_per_sr": (-1.0, 0.0, 0.0)}]})
    with pytest.raises(relume.InvalidArgumentError, match="albedo has 2 rows, the scene has .* patches"):
        relume.solve_radiosity(floor, lamp, albedo=np.full((2, 3), 0.5))
    with pytest.raises(relume.InvalidArgumentError, match="unknown key 'lamps'"):
        relume.solve_radiosity(floor, {"lamps": []})


def test_reflectance_recovers_the_albedo_a_forward_solve_was_given():
    positions, triangles = box((0, 0, 0), (3, 4, 2.5), inward=True)
    materials = np.array([0, 0, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3], np.int32)  # floor, ceiling, two wall pairs
    room = {"positions": positions, "triangles": triangles, "material": materials,
            "albedo": [[0.3, 0.25, 0.2], [0.8, 0.8, 0.75], [0.6, 0.5, 0.4], [0.2, 0.5, 0.3]]}
    lamps = [{"point_lights": [{"position_m": (1.0, 1.5, 2.0), "intensity_w_per_sr": (20.0, 20.0, 20.0)}]},
             {"point_lights": [{"position_m": (2.2, 3.0, 1.2), "intensity_w_per_sr": (15.0, 12.0, 10.0)}]}]
    observations = []
    for lighting in lamps:
        solved = relume.solve_radiosity(room, lighting, max_patch_edge_m=0.4, residual_tolerance=1e-4)
        observations.append({"lighting": lighting, "radiance": solved["radiosity"] / np.pi})  # L = B / pi
    truth = solved["albedo"]
    unknown = {**room, "albedo": np.full((4, 3), 0.5)}  # the estimate must not read the true albedo
    estimate = relume.estimate_reflectance(unknown, observations, max_patch_edge_m=0.4)
    assert estimate["converged"] and estimate["estimated"].all() and estimate["iterations"] >= 1
    error = np.abs(estimate["albedo"] - truth)
    assert np.median(error) < 0.005 and error.max() < 0.05
    # The ambient first guess (no radiosity) is far off: the indirect light is what the iterations add.
    assert np.abs(estimate["initial_albedo"] - truth).max() > 0.1
    # The estimated albedo, solved again under the second lamp, gives back what was observed.
    again = relume.solve_radiosity(unknown, lamps[1], albedo=estimate["albedo"], max_patch_edge_m=0.4,
                                   residual_tolerance=1e-4)
    observed = observations[1]["radiance"]
    assert np.median(np.abs(again["radiosity"] / np.pi / observed - 1)) < 0.01
    with pytest.raises(relume.InvalidArgumentError, match="estimate_reflectance: "):
        relume.estimate_reflectance(unknown, observations, max_patch_edge_m=0.4, albedo_tolerance=-1.0)


def test_a_chart_of_known_albedo_makes_relative_radiance_absolute():
    """An EV-only camera's photographs in unknown units; the floor's known albedo (a stand-in for a
    chart) gives the scale back, and with it the other materials' absolute albedo."""
    positions, triangles = box((0, 0, 0), (3, 4, 2.5), inward=True)
    materials = np.array([0, 0, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3], np.int32)
    room = {"positions": positions, "triangles": triangles, "material": materials,
            "albedo": [[0.3, 0.25, 0.2], [0.8, 0.8, 0.75], [0.6, 0.5, 0.4], [0.2, 0.5, 0.3]]}
    lighting = {"point_lights": [{"position_m": (1.0, 1.5, 2.0), "intensity_w_per_sr": (20.0, 20.0, 20.0)}]}
    solved = relume.solve_radiosity(room, lighting, max_patch_edge_m=0.4, residual_tolerance=1e-4)
    k_true = 7.5
    observations = [{"lighting": lighting, "radiance": solved["radiosity"] / np.pi / k_true}]
    floor = np.nonzero(solved["patches"]["material"] == 0)[0]
    references = [{"patch": int(p), "albedo": (0.3, 0.25, 0.2), "radiance": observations[0]["radiance"][p]}
                  for p in floor]
    unknown = {**room, "albedo": np.full((4, 3), 0.5)}
    estimate = relume.estimate_reflectance(unknown, observations, max_patch_edge_m=0.4, references=references)
    scale = estimate["reference_scale"]
    assert scale["converged"] and scale["patches"] == len(floor)
    assert scale["scale"] == pytest.approx(k_true, rel=0.02)
    assert scale["direct_only_scale"] < 0.95 * scale["scale"]  # the floor also gets the walls' light
    error = np.abs(estimate["albedo"] - solved["albedo"])
    assert np.median(error) < 0.01 and error.max() < 0.06
    assert relume.estimate_reflectance(unknown, observations, max_patch_edge_m=0.4)["reference_scale"] is None
    with pytest.raises(relume.InvalidArgumentError, match=r"references\[0\]: missing key 'albedo'"):
        relume.estimate_reflectance(unknown, observations, max_patch_edge_m=0.4, references=[{"patch": 0}])
