"""SH lighting: fit, irradiance and relighting against the basis written out in numpy from
processing/sh.h's table (an independent implementation), and the constant-light case."""
import numpy as np
import pytest

import relume

BAND = np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)


def basis(d):
    """Y_k(d), k = l (l + 1) + m, for (..., 3) unit directions (processing/sh.h's table)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([np.full_like(x, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                     1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)],
                    axis=-1)


def irradiance(light, normals):
    return (basis(normals) * BAND) @ light


def random_normals(shape, seed):
    n = np.random.default_rng(seed).normal(size=shape + (3,))
    return (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)


LIGHT = np.array([[3.0, 2.8, 2.5], [0.3, 0.2, 0.1], [1.1, 1.0, 0.9], [-0.4, -0.3, -0.35], [0.1, 0.05, 0.0],
                  [0.2, 0.15, 0.1], [0.3, 0.25, 0.2], [-0.1, -0.05, 0.0], [0.05, 0.04, 0.03]])


def test_sh_irradiance_matches_the_basis_and_a_constant_light():
    normals = random_normals((50,), 1).astype(np.float64)
    assert np.allclose(relume.sh_irradiance(LIGHT, normals), irradiance(LIGHT, normals), rtol=1e-5, atol=1e-6)
    # A constant light of radiance c: L00 = c sqrt(4 pi), E(n) = pi c for every normal.
    c = 0.7
    constant = np.zeros((9, 3))
    constant[0] = c * np.sqrt(4 * np.pi)
    assert np.allclose(relume.sh_irradiance(constant, normals), np.pi * c, rtol=1e-12)
    assert np.allclose(relume.sh_radiance(constant, normals), c, rtol=1e-5)


def test_fit_sh_recovers_a_known_light():
    normals = random_normals((40, 50), 2)
    albedo = np.random.default_rng(3).uniform(0.2, 0.9, (40, 50, 3)).astype(np.float32)
    radiance = (albedo * irradiance(LIGHT, normals.astype(np.float64)) / np.pi).astype(np.float32)
    light, summary = relume.fit_sh(radiance, normals, albedo=albedo)
    assert summary["usable"] and summary["order_used"] == 2 and summary["observation_count"] == 2000
    # Radiance is float32 and the basis constants have six decimals.
    assert np.abs(light - LIGHT).max() < 2e-4 * np.abs(LIGHT).max()
    # A constant light seen by a grey surface: only L00, and E = pi c everywhere.
    grey = np.full((40, 50, 3), 0.6, np.float32)
    constant, summary = relume.fit_sh(grey, normals)
    assert summary["usable"]
    assert np.allclose(constant[0], 0.6 * np.sqrt(4 * np.pi), rtol=1e-5)
    assert np.abs(constant[1:]).max() < 1e-5


def test_fit_sh_drops_the_order_when_normals_cover_little_of_the_sphere():
    normals = random_normals((30, 30), 4)
    normals[..., 2] = -np.abs(normals[..., 2]) - 4.0  # a narrow cone around -z
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    radiance = (irradiance(LIGHT, normals.astype(np.float64)) / np.pi).astype(np.float32)
    _, summary = relume.fit_sh(radiance, normals)
    assert summary["order_used"] < 2 and summary["order_reduced"] and summary["message"]
    mask = np.zeros((30, 30), bool)
    mask[0, :3] = True  # three pixels: too few for any order (four per coefficient)
    light, summary = relume.fit_sh(radiance, normals, mask=mask)
    assert not summary["usable"] and not light.any()
    with pytest.raises(relume.InvalidArgumentError, match="fit_sh: .*max_order"):
        relume.fit_sh(radiance, normals, max_order=3)


def test_fit_sh_unknown_albedo_recovers_light_up_to_the_reference_scale():
    normals = random_normals((40, 60), 5)
    labels = np.zeros((40, 60), np.int32)
    labels[:, 30:] = 1
    albedo = np.where(labels[..., None] == 0, [0.8, 0.6, 0.4], [0.3, 0.5, 0.7])
    radiance = (albedo * irradiance(LIGHT, normals.astype(np.float64)) / np.pi).astype(np.float32)
    # The segments from the colours, as the SH pipeline finds them: the two halves (equal in size:
    # either may be label 0).
    found, counts, mean_color = relume.segment_by_color(radiance.astype(np.float32), segment_count=2)
    assert counts == [1200, 1200] and found.dtype == np.int32
    assert len(np.unique(found[:, :30])) == 1 and len(np.unique(found[:, 30:])) == 1 and found[0, 0] != found[0, 59]
    labels = found if found[0, 0] == 0 else 1 - found
    light, segment_albedo, summary = relume.fit_sh_unknown_albedo(radiance, normals, labels, reference_segment=0,
                                                                  reference_albedo=(0.8, 0.6, 0.4))
    assert summary["usable"] and summary["converged"] and summary["reference_segment"] == 0
    assert np.abs(light - LIGHT).max() < 1e-3 * np.abs(LIGHT).max()
    assert np.allclose(segment_albedo, [[0.8, 0.6, 0.4], [0.3, 0.5, 0.7]], rtol=1e-3)
    # Another declared albedo scales the light per channel by true / declared.
    half, _, _ = relume.fit_sh_unknown_albedo(radiance, normals, labels, reference_segment=0,
                                              reference_albedo=(0.4, 0.6, 0.8))
    assert np.allclose(half, LIGHT * np.array([0.8 / 0.4, 1.0, 0.4 / 0.8]), rtol=1e-3, atol=1e-4)


def test_relight_sh_is_the_ratio_of_irradiances():
    normals = random_normals((20, 30), 6)
    normals[..., 2] = -np.abs(normals[..., 2])
    source = np.random.default_rng(7).uniform(0.1, 1.0, (20, 30, 3)).astype(np.float32)
    target_light = LIGHT * np.array([0.5, 1.0, 2.0])
    target_light[2] *= -1
    relit, valid, summary = relume.relight_sh(source, normals, LIGHT, target_light, ratio_radius_px=0)
    n = normals.astype(np.float64)
    expected = source * irradiance(target_light, n) / irradiance(LIGHT, n)
    assert summary["requested_pixel_count"] == 600
    assert valid.sum() == summary["relit_pixel_count"] > 0
    assert np.allclose(relit[valid], expected[valid], rtol=1e-4)
    assert np.isnan(relit[~valid]).all()
    # A normal where the source light gives no irradiance is guarded, not divided.
    dark = np.zeros((9, 3))
    dark[0] = 1.0
    dark[2] = 1.5 * 0.282095 / 0.488603  # E(n) = pi 0.282095 (1 + n_z): 0 at n = (0, 0, -1)
    normals[0, 0] = (0.0, 0.0, -1.0)
    _, valid, summary = relume.relight_sh(source, normals, dark, LIGHT)
    assert not valid[0, 0] and summary["guarded_pixel_count"] >= 1


def test_relight_sh_filters_the_ratio_of_noisy_normals_by_default():
    # A flat, evenly lit face whose normals are noisy: its ratio is one value, which the
    # default joint bilateral filter of the ratio recovers far better than each pixel alone.
    rng = np.random.default_rng(3)
    normals = np.zeros((24, 24, 3), np.float32)
    normals[..., 2] = -1.0
    normals += rng.normal(0.0, 0.07, normals.shape).astype(np.float32)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    source = np.full((24, 24, 3), 0.5, np.float32)
    target_light = LIGHT * np.array([0.5, 1.0, 2.0])
    target_light[2] *= -1
    flat = np.array([0.0, 0.0, -1.0])
    truth = 0.5 * irradiance(target_light, flat) / irradiance(LIGHT, flat)
    each, valid_each, _ = relume.relight_sh(source, normals, LIGHT, target_light, ratio_radius_px=0)
    filtered, valid, _ = relume.relight_sh(source, normals, LIGHT, target_light)
    assert valid.all() and valid_each.all()
    error_each = np.sqrt(np.mean((each - truth) ** 2))
    error_filtered = np.sqrt(np.mean((filtered - truth) ** 2))
    assert error_filtered < 0.5 * error_each, (error_each, error_filtered)
    with pytest.raises(relume.InvalidArgumentError, match="relight_sh"):
        relume.relight_sh(source, normals, LIGHT, target_light, ratio_range_sigma=0.0)


def test_fit_nonnegative_light_follows_a_lamp_that_order_two_sh_cannot():
    """Two lamps and a dim sky, clamped cosines computed here in numpy: the non-negative light's
    ratio relighting stays within a few per cent where order-2 SH's is several times worse."""
    up = np.array([0.0, -1.0, 0.0])

    def lamps(key, fill):
        key, fill = np.asarray(key) / np.linalg.norm(key), np.asarray(fill) / np.linalg.norm(fill)
        return lambda n: (np.maximum(0, n @ key)[..., None] * [3.0, 2.8, 2.5]
                          + np.maximum(0, n @ fill)[..., None] * [0.5, 0.6, 0.8]
                          + np.pi * np.array([0.05, 0.07, 0.1]) * (1 + n @ up)[..., None] / 2)

    e_src, e_dst = lamps([0.6, -0.5, -0.62], [-0.7, 0.1, -0.7]), lamps([-0.3, -0.8, -0.5], [0.8, 0.3, -0.5])
    normals = random_normals((60, 60), 9)
    normals[..., 2] = -np.abs(normals[..., 2])  # facing the camera
    n64 = normals.astype(np.float64)
    albedo = np.full((60, 60, 3), 0.5, np.float32)
    src = (albedo * e_src(n64) / np.pi).astype(np.float32)
    dst = (albedo * e_dst(n64) / np.pi).astype(np.float32)
    mask = np.zeros((60, 60), bool)
    mask[::2, ::2] = True  # 900 samples
    light_src, summary = relume.fit_nonnegative_light(src, normals, albedo=albedo, mask=mask)
    light_dst, _ = relume.fit_nonnegative_light(dst, normals, albedo=albedo, mask=mask)
    assert summary["usable"] and summary["observation_count"] == 900
    directions, irradiance_k = light_src
    assert directions.shape == irradiance_k.shape and directions.shape[1] == 3
    assert (irradiance_k >= 0).all() and np.allclose(np.linalg.norm(directions, axis=1), 1.0)

    def error(relit, valid):
        d = (relit - dst)[valid]
        return np.sqrt((d * d).sum() / (dst[valid] ** 2).sum())

    relit, valid, s = relume.relight_nonnegative(src, normals, light_src, light_dst, ratio_radius_px=0)
    assert s["relit_pixel_count"] > 3000
    sh_src, _ = relume.fit_sh(src, normals, albedo=albedo, mask=mask)
    sh_dst, _ = relume.fit_sh(dst, normals, albedo=albedo, mask=mask)
    relit_sh, valid_sh, _ = relume.relight_sh(src, normals, sh_src, sh_dst, ratio_radius_px=0)
    assert error(relit, valid) < 0.04
    assert error(relit, valid) < error(relit_sh, valid_sh) / 3
    with pytest.raises(relume.InvalidArgumentError, match="directions, irradiance"):
        relume.relight_nonnegative(src, normals, directions, light_dst)
