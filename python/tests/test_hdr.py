"""relume.recover_response and relume.merge_hdr on a synthetic bracket made in numpy: a known
scene radiance, a known gamma response, three exposures."""
import numpy as np
import pytest

import relume

GAMMA = 2.2
EXPOSURES_S = [1.0 / 16.0, 0.25, 1.0]


def encode(exposure, rng):
    """The camera: code = 255 * (exposure clipped to 1) ^ (1 / gamma), with a little noise."""
    linear = np.clip(exposure, 0.0, 1.0) ** (1.0 / GAMMA)
    codes = 255.0 * linear + rng.normal(0.0, 0.3, exposure.shape)
    return np.clip(np.rint(codes), 0, 255).astype(np.uint8)


def synthetic_bracket(height=96, width=128, seed=3):
    rng = np.random.default_rng(seed)
    # Smooth log-radiance over 2.5 decades, a different tint per channel.
    y, x = np.mgrid[0:height, 0:width]
    base = -2.3 + 2.4 * (x / width) + 0.3 * np.sin(y / 9.0)
    tint = np.array([1.0, 0.8, 0.55])
    radiance = (10.0 ** base)[..., None] * tint * np.exp(rng.normal(0.0, 0.05, (height, width, 3)))
    frames = [encode(radiance * t, rng) for t in EXPOSURES_S]
    return radiance.astype(np.float32), frames


def test_recover_and_merge_match_the_truth_after_one_scale_per_channel():
    truth, frames = synthetic_bracket()
    response, summary = relume.recover_response(frames, EXPOSURES_S)
    assert summary["usable"], summary["brief"]
    assert response.shape == (3, 256) and response.dtype == np.float64
    # X(z) of a gamma camera is proportional to z^gamma: compare over the well-exposed codes.
    z = np.arange(20, 240)
    for c in range(3):
        expected = (z / 128.0) ** GAMMA
        assert np.max(np.abs(response[c, z] / expected - 1.0)) < 0.05, c

    radiance, status, contributors, merge_summary = relume.merge_hdr(frames, EXPOSURES_S, response, full_output=True)
    assert radiance.shape == truth.shape and radiance.dtype == np.float32
    assert status.shape == truth.shape[:2] and status.dtype == np.uint8
    assert contributors.dtype == np.uint16 and merge_summary["frames"] == 3
    good = status == 0
    assert good.mean() > 0.95
    errors = []
    for c in range(3):
        r, t = radiance[..., c][good], truth[..., c][good]
        scale = np.dot(r, t) / np.dot(r, r)  # the one free scale of a recovered response
        errors.append(np.abs(scale * r / t - 1.0))
    errors = np.concatenate(errors)
    print(f"HDR relative error after one scale per channel: median {np.median(errors):.4f}, "
          f"95th percentile {np.percentile(errors, 95):.4f}")
    assert np.median(errors) < 0.02
    assert np.percentile(errors, 95) < 0.05


def test_merge_reads_non_contiguous_frames_and_returns_the_same():
    _, frames = synthetic_bracket(48, 64)
    response, _ = relume.recover_response(frames, EXPOSURES_S)
    contiguous = relume.merge_hdr(frames, EXPOSURES_S, response)
    # Every other column of a twice-as-wide array: a strided view, copied once inside.
    wide = [np.repeat(f, 2, axis=1)[:, ::2] for f in frames]
    assert not wide[0].flags["C_CONTIGUOUS"]
    assert np.array_equal(relume.merge_hdr(wide, EXPOSURES_S, response), contiguous)


def test_bad_brackets_raise_with_relumes_message():
    _, frames = synthetic_bracket(32, 32)
    with pytest.raises(relume.InvalidArgumentError, match="dtype uint8"):
        relume.recover_response([f.astype(np.float32) for f in frames], EXPOSURES_S)
    with pytest.raises(relume.InvalidArgumentError):
        relume.recover_response(frames[:1], EXPOSURES_S[:1])  # relume needs two frames
    with pytest.raises(relume.InvalidArgumentError):
        relume.recover_response(frames, [1.0, -1.0, 2.0])
    with pytest.raises(relume.InvalidArgumentError, match="response method 'nope' is unknown"):
        relume.recover_response(frames, EXPOSURES_S, method="nope")
    response, _ = relume.recover_response(frames, EXPOSURES_S)
    with pytest.raises(ValueError):
        relume.merge_hdr([frames[0], frames[1][:16]], EXPOSURES_S[:2], response)  # sizes differ
