"""A camera response the CLI recorded in a session, read from Python (Session.calibrations) and
used to merge the session's camera-encoded brackets: the radiance `relume process` writes, bit
for bit, step by step (merge_hdr with the stored curve) and in one call (linear_radiance)."""
import numpy as np

import relume
from conftest import SOURCE_DIR, read_json


def test_a_recorded_response_merges_the_brackets_as_relume_process_does(tmp_path, cli):
    session_dir = tmp_path / "session"
    # An EV-only phone camera with 8-bit encoded output: two brackets.
    cli("capture", "--rig", SOURCE_DIR / "tests/data/rigs/sim-indoor-small.yaml", "--out", session_dir)
    cli("calibrate", "response", "--session", session_dir, "--frames", "bracket:1", "--out", tmp_path / "resp.json")
    cli("process", session_dir, "--pipeline", "radiance", "--out", tmp_path / "cli")
    session = relume.Session(session_dir)
    recorded = [c for c in session.calibrations if c["kind"] == "response"]
    assert len(recorded) == 1 and recorded[0]["device"] == session.frames[0]["device"]
    response = np.array(recorded[0]["data"]["response"]["inverse"])
    assert response.shape == (3, 256) and np.allclose(response[:, 128], 1.0)  # X(128) = 1
    assert np.array_equal(response, read_json(tmp_path / "resp.json")["response"]["inverse"])

    brackets = read_json(tmp_path / "cli" / "summary.json")["metrics"]["brackets"]
    assert len(brackets) == 2
    for bracket in brackets:
        frames = [f for f in session.frames if f["id"] in bracket["frames"]]
        assert all(f["encoding"] == "camera_response" and f["exposure_time_s"] is None for f in frames)
        pixels = [session.load_image(f["id"]) for f in frames]
        assert all(p.dtype == np.uint8 for p in pixels)
        # EV-only: the relative exposure of a frame is 2^EV (pipeline/radiance.h).
        radiance = relume.merge_hdr(pixels, [2.0 ** f["ev_compensation"] for f in frames], response)
        expected = relume.load_radiance_exr(tmp_path / "cli" / bracket["exr"])
        assert np.array_equal(radiance, expected, equal_nan=True), np.nanmax(np.abs(radiance - expected))
        linear = session.linear_radiance(f"bracket:{frames[0]['bracket_id']}")
        assert linear["response_source"] == "recorded" and linear["response_id"] == recorded[0]["id"]
        assert np.array_equal(linear["radiance"], expected, equal_nan=True)
        # Without the recorded curve each bracket recovers its own: bracket 1's is the recorded one
        # (`calibrate response` recovered it from bracket 1 with the same options), so its merge
        # differs only by the exposure ratios the recovery refines beside the curve (EV-only,
        # RecoverResponseFromEv: measured 3.6e-4 at most on this 3-frame bracket; none for 2
        # frames, whose ratio is anchored). Bracket 2's curve is its own: up to 28 % apart.
        own = session.linear_radiance(f"bracket:{frames[0]['bracket_id']}", use_calibrations=False)
        assert own["response_source"].startswith("recovered from the bracket")
        relative = np.abs(own["radiance"] - expected) / np.maximum(expected, 1e-9)
        if frames[0]["bracket_id"] == 1:
            assert np.nanmax(relative) < 2e-3, np.nanmax(relative)
        else:
            assert np.nanmax(relative) > 1e-2, np.nanmax(relative)
