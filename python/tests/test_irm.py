"""Issue 22's acceptance test: a captured session loaded, its brackets merged and the first relit
to the second's light with IRM, step by step from Python (Session, merge_hdr, Session.camera and
Session.scene_mesh from the session's scene model, enu_direction, irm_relight), against what
`relume process --pipeline irm` writes for the same session."""
import numpy as np
import pytest

import relume
from conftest import read_json
from test_session import relative_exposure


def bracket_view(session, bracket_id):
    """One bracket as irm_relight's inputs, made as the pipeline makes them: the merged radiance,
    the mask of pixels badly exposed everywhere, the device's camera and the sun of the first frame."""
    frames = [f for f in session.frames if f["bracket_id"] == bracket_id]
    first = frames[0]
    radiance, status, _, _ = relume.merge_hdr([session.load_image(f["id"]) for f in frames],
                                              [relative_exposure(f) for f in frames], "linear",
                                              black_level=first["black_level"], white_level=first["white_level"],
                                              bits_per_sample=first["bits_per_sample"], full_output=True)
    return {"radiance": radiance, "mask": status != 0, "camera": session.camera(first["device"]),
            "sun_dir": relume.enu_direction(first["sun_azimuth_deg"], first["sun_elevation_deg"])}


def relight(mesh, source, target, **options):
    return relume.irm_relight(mesh, source["radiance"], target["radiance"], source["camera"], target["camera"],
                              source["sun_dir"], target["sun_dir"], source_mask=source["mask"],
                              target_mask=target["mask"], **options)


@pytest.fixture(scope="module")
def irm_inputs(tiny_session):
    session = relume.Session(tiny_session)
    return session, session.scene_mesh(), bracket_view(session, 1), bracket_view(session, 2)


def test_irm_relight_in_python_gives_the_numbers_relume_process_writes(tiny_session, irm_inputs, tmp_path, cli):
    cli("process", tiny_session, "--pipeline", "irm", "--source", "bracket:1", "--target", "bracket:2", "--out",
        tmp_path / "cli")
    summary = read_json(tmp_path / "cli" / "summary.json")
    _, mesh, source, target = irm_inputs
    assert mesh["positions"].shape[0] == summary["metrics"]["irm"]["mesh"]["vertices"]
    assert mesh["triangles"].shape[0] == summary["metrics"]["irm"]["mesh"]["triangles"]

    result = relight(mesh, source, target)

    relit_exr = next(o["path"] for o in summary["outputs"] if o["path"].endswith("relit.exr"))
    expected = relume.load_radiance_exr(tmp_path / "cli" / relit_exr)
    assert result["relit"].dtype == np.float32 and result["relit"].shape == expected.shape
    assert np.array_equal(result["relit"], expected, equal_nan=True), np.nanmax(np.abs(result["relit"] - expected))
    metrics = summary["metrics"]["irm"]
    for key, value in result["summary"].items():
        if not key.endswith("_s"):  # timings differ run to run
            assert value == metrics[key], key
    assert result["irms"]["single_map"] == metrics["single_map"]
    assert np.count_nonzero(result["status"] == 1) == metrics["pixels_relit"]
    assert np.count_nonzero(result["status"] == 3) == metrics["pixels_masked"]
    # The ratio maps themselves: the irm-build stage's irms.json (floats through JSON, exact).
    stage = next(d for d in (tmp_path / "cli" / "stages").iterdir() if d.name.startswith("irm-build-"))
    stored = read_json(stage / "irms.json")
    assert result["irms"]["samples_used"] == stored["samples_used"] > 0
    for stored_map in stored["maps"]:
        ours = result["irms"]["maps"][stored_map["kind"]]
        bins = stored_map["bins"]
        ratio = np.array([[np.nan if c is None else c for c in r] for r in stored_map["ratio"]], np.float32)
        assert np.array_equal(ours["ratio"], ratio.reshape(bins, bins, 3), equal_nan=True), stored_map["kind"]
        assert np.array_equal(ours["count"].ravel(), stored_map["count"])
        assert np.array_equal(ours["source"].ravel(), stored_map["source"])
    assert sum(m["count"].sum() for m in result["irms"]["maps"].values()) == stored["samples_used"]
    # The relighting did something: the source's overlap error against the target falls.
    assert metrics["overlap_vertex_rms_after"] < 0.1 * metrics["overlap_vertex_rms_before"]


def test_irm_relight_options_change_the_result_and_are_checked(irm_inputs):
    _, mesh, source, target = irm_inputs
    default = relight(mesh, source, target)
    coarse = relight(mesh, source, target, bins=4, threads=1)
    assert coarse["summary"]["pixels_relit"] > 0
    relit = default["status"] == 1
    assert not np.array_equal(coarse["relit"][relit], default["relit"][relit])
    with pytest.raises(relume.InvalidArgumentError, match="irm_relight: .*bins"):
        relight(mesh, source, target, bins=0)
    with pytest.raises(relume.InvalidArgumentError, match="fill='magic'"):
        relight(mesh, source, target, fill="magic")
    with pytest.raises(relume.InvalidArgumentError, match="source_radiance: expected an HxWx3 float32"):
        relume.irm_relight(mesh, source["radiance"][..., 0], target["radiance"], source["camera"], target["camera"],
                           source["sun_dir"], target["sun_dir"])


def test_session_camera_and_enu_direction(irm_inputs):
    session, _, _, _ = irm_inputs
    camera = session.camera(session.frames[0]["device"])
    assert (camera["width"], camera["height"]) == (session.frames[0]["width"], session.frames[0]["height"])
    rotation = camera["world_from_camera"][:3, :3]
    assert np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-9)
    assert camera["distortion"] == [] and camera["device_id"] == session.frames[0]["device"]
    with pytest.raises(relume.InvalidArgumentError, match="scene model has no camera 'nosuch'"):
        session.camera("nosuch")
    # East at azimuth 90 deg on the horizon, up at elevation 90 deg, north at azimuth 0.
    assert np.allclose(relume.enu_direction(90.0, 0.0), [1, 0, 0], atol=1e-12)
    assert np.allclose(relume.enu_direction(0.0, 0.0), [0, 1, 0], atol=1e-12)
    assert np.allclose(relume.enu_direction(123.0, 90.0), [0, 0, 1], atol=1e-12)
    e = np.radians(30.0)
    assert np.allclose(relume.enu_direction(180.0, 30.0), [0, -np.cos(e), np.sin(e)], atol=1e-12)
