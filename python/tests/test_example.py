"""The example script runs and writes its figure."""

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "simulate_identify.py"


def test_simulate_identify_example(tmp_path):
    out = tmp_path / "figure.png"
    run = subprocess.run([sys.executable, str(EXAMPLE), str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "wrote" in run.stdout
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
