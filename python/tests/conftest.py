"""Shared fixtures: the module under test, the `relume` CLI it is compared with, and a small
simulated session captured once per test run."""
import json
import os
import pathlib
import subprocess

import pytest

import relume  # noqa: F401  (fails the whole run early when the module is not on PYTHONPATH)

SOURCE_DIR = pathlib.Path(os.environ.get("RELUME_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
RELUME_BINARY = pathlib.Path(os.environ.get("RELUME_BINARY", SOURCE_DIR / "build/release/apps/relume/relume"))


def run_cli(*args, input_text=None, check=True):
    """Runs `relume ARGS...`; returns the CompletedProcess (text output)."""
    result = subprocess.run([str(RELUME_BINARY), *map(str, args)], input=input_text, capture_output=True, text=True,
                            timeout=600)
    if check and result.returncode != 0:
        raise AssertionError(f"relume {' '.join(map(str, args))} failed ({result.returncode}):\n"
                             f"{result.stdout}\n{result.stderr}")
    return result


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE_DIR


@pytest.fixture(scope="session")
def cli():
    assert RELUME_BINARY.exists(), f"the relume CLI is not built: {RELUME_BINARY}"
    return run_cli


@pytest.fixture(scope="session")
def tiny_session(tmp_path_factory, cli):
    """A session of the tiny simulated IRM rig: two brackets of a 14-bit raw camera (1 s)."""
    folder = tmp_path_factory.mktemp("capture") / "session"
    cli("capture", "--rig", SOURCE_DIR / "tests/data/rigs/sim-tiny-irm.yaml", "--out", folder)
    return folder


def read_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)
