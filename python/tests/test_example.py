"""python/examples/example.py (docs/python.md's worked example) runs to the end."""
import os
import subprocess
import sys

from conftest import SOURCE_DIR


def test_the_worked_example_runs(tiny_session, tmp_path):
    result = subprocess.run([sys.executable, str(SOURCE_DIR / "python/examples/example.py"), str(tiny_session),
                             str(tmp_path / "irm")], capture_output=True, text=True, timeout=600, env=os.environ)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "sun: highest" in result.stdout
    assert "irm: four IRMs" in result.stdout
    assert "the same as the pipeline's relit.exr" in result.stdout
    assert "normals: 19200 valid" in result.stdout
    assert (tmp_path / "irm" / "summary.json").exists()
