"""Depth filters and normals from depth, against analytic cases: a plane's normals are its true
normal, filters keep what they must keep and blend as their equations say."""
import numpy as np
import pytest

import relume

INTRINSICS = {"width": 80, "height": 60, "fx": 70.0, "fy": 72.0, "cx": 40.5, "cy": 29.0}


def rays(k=INTRINSICS):
    """Per-pixel camera rays with z = 1 (pixel centres at +0.5)."""
    u, v = np.meshgrid(np.arange(k["width"]) + 0.5, np.arange(k["height"]) + 0.5)
    return np.stack([(u - k["cx"]) / k["fx"], (v - k["cy"]) / k["fy"], np.ones_like(u)], axis=-1)


def plane_depth(normal, offset):
    """Depth of the plane normal . p = offset seen through every pixel (metres, float32)."""
    return (offset / (rays() @ normal)).astype(np.float32)


def test_the_normals_of_a_plane_are_its_normal():
    normal = np.array([0.25, -0.15, -1.0])
    normal /= np.linalg.norm(normal)  # facing the camera: n . p = -2 < 0
    depth = plane_depth(normal, -2.0)
    depth[20:24, 30:34] = np.nan  # a hole: the smooth estimate still sees a plane around it
    result = relume.estimate_normals(depth, INTRINSICS)
    n = result["normals"]
    assert n.dtype == np.float32 and n.shape == (60, 80, 3)
    valid = result["valid"]
    assert valid.dtype == bool and not valid[20:24, 30:34].any()
    assert valid.sum() == 60 * 80 - 16 and result["invalid_count"] == 0
    assert np.abs(n[valid] - normal).max() < 2e-4
    # Beside the hole and the border the window's box does not fit: smaller boxes, and on this
    # noise-free depth jets (method 5) refine those pixels.
    assert result["integral_count"] + result["cross_count"] + result["jet_count"] == valid.sum()
    assert result["jet_count"] > 0 and (result["method"] == 5).sum() == result["jet_count"]
    assert result["crease_count"] == 0  # a plane has no crease
    assert set(np.unique(result["method"][valid])) <= {1, 2, 5}
    no_jets = relume.estimate_normals(depth, INTRINSICS, jet_radius_px=0)
    assert no_jets["jet_count"] == 0 and no_jets["cross_count"] > 0
    assert np.abs(no_jets["normals"][valid] - normal).max() < 2e-4
    # Cross products only (window 0) give the same plane.
    cross = relume.estimate_normals(depth, INTRINSICS, window_radius_px=0)
    assert cross["cross_count"] == valid.sum() and np.abs(cross["normals"][valid] - normal).max() < 2e-4
    # Depth said to be noisy: beside the hole and the border the neighbours' 3 x 3 boxes take
    # over from one-pixel differences (still the plane); without smaller boxes and neighbours'
    # boxes, more pixels fall back to one-pixel differences.
    told = relume.estimate_normals(depth, INTRINSICS, depth_noisy=True)
    assert told["neighbour_box_count"] > 0 and told["creases_skipped_for_noise"] is None and told["jet_count"] == 0
    assert (told["method"] == 4).sum() == told["neighbour_box_count"]
    assert np.abs(told["normals"][valid] - normal).max() < 2e-4
    old = relume.estimate_normals(depth, INTRINSICS, min_window_radius_px=3, neighbour_boxes_on_noisy_depth=False,
                                  depth_noisy=True)
    assert old["neighbour_box_count"] == 0 and old["cross_count"] > told["cross_count"]


def test_a_crease_keeps_each_faces_normal():
    """A ridge: two planes meeting along a line, depth continuous across it. The smooth box
    blends both planes within its radius of the line; the crease refinement does not."""
    na, nb = np.array([0.5, -0.1, -1.0]), np.array([-0.5, -0.1, -1.0])
    na, nb = na / np.linalg.norm(na), nb / np.linalg.norm(nb)
    da, db = plane_depth(na, -2.0), plane_depth(nb, -2.03)
    depth = np.maximum(da, db)  # the solid behind both planes: a ridge facing the camera
    on_a = da >= db
    truth = np.where(on_a[..., None], na, nb)
    near = np.zeros_like(on_a)
    for shift in range(-3, 4):
        near |= np.roll(on_a, shift, axis=1) != on_a
    near[:, :4] = near[:, -4:] = False
    near[:4, :] = near[-4:, :] = False
    assert near.sum() > 200

    def angles(result):
        c = np.clip(np.sum(result["normals"][near] * truth[near], axis=-1), -1.0, 1.0)
        return np.degrees(np.arccos(c))

    blended = relume.estimate_normals(depth, INTRINSICS, refine_creases=False)
    refined = relume.estimate_normals(depth, INTRINSICS)
    assert blended["crease_count"] == 0 and refined["crease_count"] > 0
    assert np.median(angles(blended)) > 5.0
    assert np.percentile(angles(refined), 99) < 0.5
    assert set(np.unique(refined["method"][refined["valid"]])) <= {1, 2, 3, 5}  # 5: jets at the border
    assert refined["creases_skipped_for_noise"] is None
    # With 2 mm of noise the depth measures noisy: no crease is refined, and the result says why
    # (the 3 x 3 fits would follow the noise); forced with a threshold of 0 they run.
    noisy = depth + np.random.default_rng(3).normal(0.0, 0.002, depth.shape).astype(np.float32)
    skipped = relume.estimate_normals(noisy, INTRINSICS)
    assert skipped["crease_count"] == 0 and "mm at 1 m" in skipped["creases_skipped_for_noise"]
    forced = relume.estimate_normals(noisy, INTRINSICS, refine_creases_below_noise_at_1m_m=0.0)
    assert forced["creases_skipped_for_noise"] is None


def test_vertex_map_unprojects_each_pixel():
    depth = np.full((60, 80), 2.0, np.float32)
    vertices = relume.vertex_map(depth, INTRINSICS)
    assert np.allclose(vertices, 2.0 * rays(), rtol=1e-6)


def test_normal_options_and_inputs_are_checked():
    depth = np.ones((60, 80), np.float32)
    with pytest.raises(relume.InvalidArgumentError, match="estimate_normals: .*window_radius_px"):
        relume.estimate_normals(depth, INTRINSICS, window_radius_px=-1)
    with pytest.raises(relume.InvalidArgumentError, match="depth_m: expected dtype float32, got float64"):
        relume.estimate_normals(depth.astype(np.float64), INTRINSICS)
    with pytest.raises(relume.InvalidArgumentError):
        relume.estimate_normals(depth[:, :40], INTRINSICS)  # not the intrinsics' size


def test_bilateral_filter_keeps_edges_and_holes_and_reduces_noise():
    rng = np.random.default_rng(3)
    step = np.where(np.arange(80)[None, :] < 40, 1.0, 1.5).repeat(60, axis=0).astype(np.float32)
    step[10, 10] = np.nan
    filtered = relume.bilateral_filter_depth(step)
    assert np.isnan(filtered[10, 10]) and np.isfinite(np.delete(filtered.ravel(), 10 * 80 + 10)).all()
    # No averaging across the 0.5 m step (far beyond 3 range sigmas).
    assert np.allclose(filtered, step, rtol=0, atol=1e-6, equal_nan=True)
    noisy = (1.0 + rng.normal(0.0, 0.002, (60, 80))).astype(np.float32)
    smoothed = relume.bilateral_filter_depth(noisy, radius_px=2, spatial_sigma_px=1.5)
    assert np.std(smoothed - 1.0) < 0.5 * np.std(noisy - 1.0)
    with pytest.raises(relume.InvalidArgumentError, match="bilateral_filter_depth: "):
        relume.bilateral_filter_depth(noisy, spatial_sigma_px=0.0)


def test_temporal_filter_blends_as_equation_2():
    current = np.full((4, 5), 1.0, np.float32)
    previous = np.full((4, 5), 1.003, np.float32)
    previous[0, 0] = 1.5  # beyond the gate: the current value stays
    blended, count = relume.temporal_filter_depth(current, previous, weight=2.0)
    assert count == 19
    assert blended[0, 0] == 1.0
    assert blended[1, 1] == pytest.approx((1.0 * 3 + 1.003 * 2) / 5, rel=1e-6)
    first, none = relume.temporal_filter_depth(current, None)
    assert none == 0 and np.array_equal(first, current)


def test_depth_noise_estimate_finds_the_noise_added():
    rng = np.random.default_rng(7)
    normal = np.array([0.1, 0.2, -1.0]) / np.linalg.norm([0.1, 0.2, -1.0])
    clean = plane_depth(normal, -1.0)
    assert relume.estimate_depth_noise(clean)["sigma_at_1m_m"] < 1e-5
    noisy = (clean + rng.normal(0.0, 0.002, clean.shape) * clean**2).astype(np.float32)
    estimate = relume.estimate_depth_noise(noisy)
    assert estimate["sigma_at_1m_m"] == pytest.approx(0.002, rel=0.15)
    assert not estimate["noise_free"] and estimate["samples"] > 1000
