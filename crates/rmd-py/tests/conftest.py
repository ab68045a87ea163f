"""Shared fixtures of the Python package's tests (run them with tests/python/run.sh)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import List

import pytest

REPO = Path(__file__).resolve().parents[3]
LEG4 = REPO / "examples" / "robots" / "leg4.toml"

# Gains stiffer than the servo's defaults, so that the joints end close to their targets
# (no load in the simulator: what is left is the motors' friction against kp).
STIFF_SERVO = """
[defaults]
kp_nm_per_rad = 80.0
kd_nm_s_per_rad = 2.0
max_velocity_rad_s = 3.0
"""


@pytest.fixture(scope="session")
def rmd_bin() -> Path:
    """The `rmd` tool built from this checkout (tests/python/run.sh builds it and sets RMD_BIN)."""
    path = Path(os.environ.get("RMD_BIN", REPO / "target" / "debug" / "rmd"))
    if not path.is_file():
        pytest.fail(f"{path} is missing: run `cargo build -p rmd-cli` (tests/python/run.sh does)")
    return path


def run_rmd(rmd_bin: Path, args: List[str], stdin: str = "") -> subprocess.CompletedProcess:
    """Runs `rmd ARGS` with `stdin`, capturing text output."""
    return subprocess.run(
        [str(rmd_bin), *args], input=stdin, capture_output=True, text=True, timeout=60
    )


@pytest.fixture(scope="session")
def leg4() -> Path:
    """The four-joint leg of examples/robots/leg4.toml."""
    return LEG4
