"""relume.Session and relume.process on a session captured with the CLI, against what the CLI
reads and writes for the same session."""
import datetime
import shutil
import sqlite3

import numpy as np
import pytest

import relume
from conftest import read_json


def without_timings(value):
    """A summary's metrics less the wall-clock figures (keys ending in _s or seconds)."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if not k.endswith(("_s", "seconds"))}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def test_session_frames_carry_their_metadata(tiny_session):
    session = relume.Session(tiny_session)
    frames = session.frames
    assert len(frames) == 3  # sim-tiny-irm: brackets of one and two raw frames
    assert {f["stream"] for f in frames} == {"still"}
    assert sorted({f["bracket_id"] for f in frames}) == [b["id"] for b in session.brackets]
    site = session.info["site"]
    for f in frames:
        utc = datetime.datetime.fromisoformat(f["utc"].replace("Z", "+00:00"))
        assert utc.timestamp() == pytest.approx(f["unix_seconds"], abs=1e-3)
        assert f["exposure_time_s"] > 0.0
        # The recorder stored the sun from the same library with its default atmosphere.
        elevation, azimuth = relume.sun_positions(f["unix_seconds"], site["lat_deg"], site["lon_deg"],
                                                  site["height_m"])
        assert elevation == pytest.approx(f["sun_elevation_deg"], abs=1e-6)
        assert azimuth == pytest.approx(f["sun_azimuth_deg"], abs=1e-6)


def test_load_image_returns_the_stored_pixels(tiny_session):
    session = relume.Session(tiny_session)
    frame = session.frames[0]
    pixels = session.load_image(frame["id"])
    assert pixels.shape[:2] == (frame["height"], frame["width"])
    expected = np.uint8 if frame["bits_per_sample"] <= 8 else np.uint16
    assert pixels.dtype == expected
    assert pixels.max() > frame["black_level"]  # not an empty buffer
    assert pixels.max() <= frame["white_level"]


def test_session_errors_raise_with_relumes_message(tiny_session, tmp_path):
    with pytest.raises(relume.IoError, match="no session here") as error:
        relume.Session(tmp_path)
    assert isinstance(error.value, OSError) and error.value.path == str(tmp_path)
    session = relume.Session(tiny_session)
    with pytest.raises(relume.InvalidArgumentError, match="has no frame 999"):
        session.load_image(999)
    with pytest.raises(relume.InvalidArgumentError, match="not a depth frame"):
        session.load_depth(session.frames[0]["id"])


def test_process_irm_gives_the_numbers_relume_process_writes(tiny_session, tmp_path, cli):
    selectors = ["--source", "bracket:1", "--target", "bracket:2"]
    cli("process", tiny_session, "--pipeline", "irm", *selectors, "--out", tmp_path / "cli")
    expected = read_json(tmp_path / "cli" / "summary.json")

    result = relume.process(tiny_session, "irm", source="bracket:1", target="bracket:2", out_dir=tmp_path / "py")
    summary = result["pipelines"]["irm"]["summary"]
    assert summary == read_json(tmp_path / "py" / "summary.json")
    assert result["report"].endswith("report.html")
    # Computed afresh (different output folders share no stages), the same figures.
    cache_actions = [d["action"] for d in summary["decisions"] if d.get("cache")]
    assert cache_actions and set(cache_actions) == {"run"}, summary["decisions"]
    assert summary["headline"] == expected["headline"]
    assert summary["knobs"] == expected["knobs"]
    assert without_timings(summary["metrics"]) == without_timings(expected["metrics"])
    assert summary["metrics"]["truth"]["relit"]["relative_rms_lit"] < 0.04

    # The radiance stage that merged the brackets, and the settings as keyword arguments.
    again = relume.process(tiny_session, "irm", source="bracket:1", target="bracket:2", out_dir=tmp_path / "py",
                           settings={"bins": 16})
    knobs = again["pipelines"]["irm"]["summary"]["knobs"]
    assert knobs["bins"] == 16


def test_unknown_settings_are_refused_like_the_cli(tiny_session, tmp_path, cli):
    refused = cli("process", tiny_session, "--pipeline", "irm", "--set", "binz=16", "--out", tmp_path / "cli",
                  check=False)
    assert refused.returncode != 0
    with pytest.raises(relume.InvalidArgumentError) as error:
        relume.process(tiny_session, "irm", settings={"binz": 16}, out_dir=tmp_path / "py")
    message = str(error.value)
    assert "binz" in message and "bins" in message  # names the key and the closest knob
    assert message in refused.stderr + refused.stdout
    assert not (tmp_path / "py" / "summary.json").exists()


def test_pipelines_lists_each_pipeline_and_its_knobs():
    pipelines = {p["name"]: p for p in relume.pipelines()}
    assert {"radiance", "irm"} <= set(pipelines)
    bins = [k for k in pipelines["irm"]["knobs"] if k["name"] == "bins"]
    assert bins and bins[0]["default"] == 32


def relative_exposure(frame):
    """The relative exposure relume's pipelines merge with: t * ISO / 100 (pipeline/radiance.cc)."""
    t = frame["exposure_time_s"]
    return t * frame["iso"] / 100.0 if frame["iso"] else t


def test_merging_a_bracket_in_python_gives_the_radiance_relume_process_writes(tiny_session, tmp_path, cli):
    """Issue 22: a captured session's bracket merged from Python, the same numbers as `relume process`."""
    cli("process", tiny_session, "--pipeline", "radiance", "--out", tmp_path / "cli")
    summary = read_json(tmp_path / "cli" / "summary.json")
    session = relume.Session(tiny_session)
    for bracket in summary["metrics"]["brackets"]:
        frames = [f for f in session.frames if f["id"] in bracket["frames"]]
        assert frames and all(f["encoding"] == "sensor_linear" for f in frames)
        pixels = [session.load_image(f["id"]) for f in frames]
        assert all(p.dtype == np.uint16 for p in pixels)
        radiance = relume.merge_hdr(pixels, [relative_exposure(f) for f in frames], "linear",
                                    black_level=frames[0]["black_level"], white_level=frames[0]["white_level"],
                                    bits_per_sample=frames[0]["bits_per_sample"])
        expected = relume.load_radiance_exr(tmp_path / "cli" / bracket["exr"])
        assert radiance.shape == expected.shape and radiance.dtype == expected.dtype == np.float32
        assert np.array_equal(radiance, expected, equal_nan=True), np.nanmax(np.abs(radiance - expected))


def test_linear_radiance_is_the_radiance_stage(tiny_session, tmp_path, cli):
    """Session.linear_radiance: the pipelines' linearisation of one bracket in one call (here raw
    frames; test_color.py checks it with a recorded colour profile)."""
    cli("process", tiny_session, "--pipeline", "radiance", "--out", tmp_path / "cli")
    summary = read_json(tmp_path / "cli" / "summary.json")
    session = relume.Session(tiny_session)
    for bracket in summary["metrics"]["brackets"]:
        bracket_id = next(f["bracket_id"] for f in session.frames if f["id"] == bracket["frames"][0])
        linear = session.linear_radiance(f"bracket:{bracket_id}")
        assert linear["frame_ids"] == bracket["frames"] and linear["response_source"] == "sensor-linear"
        assert linear["profile_id"] == 0 and linear["status"].dtype == np.uint8
        expected = relume.load_radiance_exr(tmp_path / "cli" / bracket["exr"])
        assert np.array_equal(linear["radiance"], expected, equal_nan=True)
    with pytest.raises(relume.InvalidArgumentError, match="selects 2 still brackets"):
        session.linear_radiance("all")
    with pytest.raises(relume.InvalidArgumentError, match="linear_radiance: "):
        session.linear_radiance("bracket:1", merge_black_margin=-1)


def test_a_session_from_a_newer_relume_raises_config_error_like_the_cli(tiny_session, tmp_path, cli):
    copy = tmp_path / "newer"
    shutil.copytree(tiny_session, copy)
    with sqlite3.connect(copy / "session.sqlite") as db:
        db.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    with pytest.raises(relume.ConfigError, match="written by a newer relume") as error:
        relume.Session(copy)
    assert isinstance(error.value, ValueError) and isinstance(error.value, relume.Error)
    assert error.value.key == "schema_version" and error.value.file.endswith("session.sqlite")
    refused = cli("session", "info", copy, check=False)
    assert refused.returncode != 0 and str(error.value) in refused.stderr + refused.stdout
