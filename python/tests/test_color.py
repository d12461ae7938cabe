"""The ColorChecker from Python (detect, sample, fit, apply) on a chart session captured with the
CLI, against what `relume calibrate chart` writes for it, and the profile it stores in the
session read back through Session.calibrations and applied as `relume process` applies it."""
import numpy as np
import pytest

import relume
from conftest import SOURCE_DIR, read_json
from test_session import relative_exposure

REFERENCE = SOURCE_DIR / "config/colorchecker/xrite_classic_2014_lab_d50.yaml"


@pytest.fixture(scope="module")
def chart(tmp_path_factory, cli):
    """A simulated chart session (config/rigs/sim-chart.yaml) calibrated with the CLI."""
    folder = tmp_path_factory.mktemp("chart")
    cli("capture", "--rig", SOURCE_DIR / "config/rigs/sim-chart.yaml", "--out", folder / "session")
    cli("calibrate", "chart", "--session", folder / "session", "--frames", "bracket:1", "--reference", REFERENCE,
        "--out", folder / "profile.json")
    session = relume.Session(folder / "session")
    frames = [f for f in session.frames if f["bracket_id"] == 1]
    radiance = relume.merge_hdr([session.load_image(f["id"]) for f in frames], [relative_exposure(f) for f in frames],
                                "linear", black_level=frames[0]["black_level"], white_level=frames[0]["white_level"],
                                bits_per_sample=frames[0]["bits_per_sample"])
    return {"folder": folder, "session": session, "radiance": radiance,
            "report": read_json(folder / "profile_report/chart_report.json"),
            "profile": read_json(folder / "profile.json")}


def test_detect_sample_and_fit_give_what_relume_calibrate_chart_writes(chart):
    report, profile = chart["report"], chart["profile"]
    location = relume.detect_colorchecker(relume.preview_linear(chart["radiance"]), REFERENCE)
    assert location["found"] and location["method"] == report["detection"]["method"]
    assert np.array_equal(location["corners"], np.array(report["detection"]["corners"], np.float32))
    patches = relume.sample_patches(chart["radiance"], location["corners"])
    assert patches["status"] == [p["status"] for p in report["patches"]]
    assert np.array_equal(patches["median"], [p["measured"] for p in report["patches"]])
    fit = relume.fit_colorchecker(patches["median"], REFERENCE, status=patches["status"])
    assert fit["summary"]["usable"] and fit["summary"]["patches_used"] == report["fit"]["patches_used"]
    assert np.array_equal(fit["ccm"], profile["ccm"])
    assert np.array_equal(fit["delta_e"], profile["fit"]["patch_delta_e_2000"])
    assert fit["summary"]["mean_delta_e"] == report["fit"]["mean_delta_e_2000"]
    for channel, knots in zip(fit["gain"], profile["gain"]):
        assert np.array_equal(channel["x"], knots["x"]) and np.array_equal(channel["y"], knots["y"])
    reference = relume.load_colorchecker_reference(REFERENCE)
    assert np.allclose(relume.delta_e_2000(fit["corrected_lab"], reference["lab_d50"]), fit["delta_e"], atol=1e-12)
    # The same chart from corners given by hand, in another order.
    manual = relume.chart_from_corners(location["corners"][[2, 3, 0, 1]], relume.preview_linear(chart["radiance"]),
                                       REFERENCE)
    assert manual["found"] and np.allclose(manual["corners"], location["corners"])


def test_fit_colorchecker_on_a_known_camera():
    """Patches seen through a known colour matrix and per-channel gains: the fit undoes them (Delta
    E within 1 of the floor: the reference itself as the measurement), and a patch marked
    saturated is left out. The floor is 0 except for cyan (index 17), whose reflectance is outside
    sRGB (R < 0), which the gain through (0, 0) cannot carry."""
    reference = relume.load_colorchecker_reference(REFERENCE)
    mixing = np.array([[0.9, 0.08, 0.02], [0.05, 0.85, 0.1], [0.0, 0.12, 0.88]])
    measured = (reference["linear_rgb"] @ mixing.T) * np.array([2.0, 1.5, 3.0])
    status = ["ok"] * 24
    status[5] = "saturated"
    fit = relume.fit_colorchecker(measured, REFERENCE, status=status)
    assert fit["summary"]["usable"] and fit["summary"]["patches_used"] == 23
    assert not fit["used"][5] and fit["delta_e"][5] == 0.0
    floor = relume.fit_colorchecker(reference["linear_rgb"], REFERENCE)["delta_e"]
    assert floor[17] > 1.0 and np.delete(floor, 17).max() < 1e-6
    assert np.abs(fit["delta_e"] - floor)[fit["used"]].max() < 1.0
    assert fit["summary"]["mean_delta_e"] < 0.6
    unfitted = relume.fit_colorchecker(measured, REFERENCE, fit_gain=False, fit_matrix=False)
    assert unfitted["summary"]["mean_delta_e"] > 10
    with pytest.raises(relume.InvalidArgumentError, match="fit_colorchecker: .*ridge"):
        relume.fit_colorchecker(measured, REFERENCE, ridge=-1.0)
    with pytest.raises(relume.InvalidArgumentError, match="expected 24 patches"):
        relume.fit_colorchecker(measured[:20], REFERENCE)
    with pytest.raises(relume.IoError):
        relume.fit_colorchecker(measured, "/nonexistent/chart.yaml")


def test_the_stored_profile_is_read_and_applied_as_relume_process_applies_it(chart, tmp_path, cli):
    session = relume.Session(chart["folder"] / "session")  # reopened: the calibration was stored after capture
    profiles = [c for c in session.calibrations if c["kind"] == "profile"]
    assert len(profiles) == 1 and profiles[0]["device"] == "sim:dslr"
    stored = profiles[0]["data"]
    assert stored["ccm"] == chart["profile"]["ccm"] and stored["gain"] == chart["profile"]["gain"]
    assert sorted(profiles[0]["source_frame_ids"]) == [f["id"] for f in session.frames if f["bracket_id"] == 1]

    cli("process", chart["folder"] / "session", "--pipeline", "radiance", "--out", tmp_path / "cli")
    summary = read_json(tmp_path / "cli" / "summary.json")
    expected = relume.load_radiance_exr(tmp_path / "cli" / summary["metrics"]["brackets"][0]["exr"])
    corrected = relume.apply_color_profile(chart["radiance"], stored)
    assert np.array_equal(corrected, expected, equal_nan=True), np.nanmax(np.abs(corrected - expected))
    assert not np.array_equal(corrected, chart["radiance"], equal_nan=True)
    from_file = relume.apply_color_profile(chart["radiance"], chart["folder"] / "profile.json")
    assert np.array_equal(from_file, corrected, equal_nan=True)
    # In one call, the radiance stage's linearisation with the recorded profile.
    linear = session.linear_radiance("bracket:1")
    assert linear["profile_id"] == profiles[0]["id"]
    assert np.array_equal(linear["radiance"], expected, equal_nan=True)
    raw = session.linear_radiance("bracket:1", use_calibrations=False)
    assert raw["profile_id"] == 0 and np.array_equal(raw["radiance"], chart["radiance"], equal_nan=True)
