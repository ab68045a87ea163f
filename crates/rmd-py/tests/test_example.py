"""examples/python/leg4_wave.py runs to its end on simulated motors."""

from __future__ import annotations

import re
import subprocess
import sys

from conftest import REPO


def test_leg4_wave_runs_on_the_simulator_and_returns_to_its_start(tmp_path):
    mcap = tmp_path / "wave.mcap"
    out = subprocess.run(
        [
            sys.executable,
            str(REPO / "examples" / "python" / "leg4_wave.py"),
            "--virtual-time",
            "--cycles",
            "1",
            "--mcap",
            str(mcap),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("simulated motors, virtual time: joints hip_aa, hip_fe, knee, ankle")
    error = float(re.search(r"back at the start within ([0-9.]+)°", out.stdout).group(1))
    assert error < 1.0, out.stdout
    assert "every motor off: True" in out.stdout
    assert mcap.stat().st_size > 0
