"""The wheel tests/python/run.sh built and installed: one abi3 wheel for every CPython >= 3.9,
its extension module stripped, its version the crate's; it installs into a fresh venv with
nothing but NumPy and runs the example; the stubs match the native module (mypy's stubtest)
and type-check the package and the example (mypy)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import venv
import zipfile
from importlib.metadata import version
from pathlib import Path

import pytest

import rmd_rt
from conftest import REPO


def env_path(name: str) -> Path:
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set: run the suite with tests/python/run.sh")
    return Path(value)


@pytest.fixture(scope="module")
def wheel() -> Path:
    return env_path("RMD_WHEEL")


def crate_version() -> str:
    text = (REPO / "Cargo.toml").read_text()
    (found,) = re.findall(r'(?m)^\[workspace\.package\][^\[]*?^version = "([^"]+)"', text)
    return found


def test_one_abi3_wheel_for_every_cpython_from_3_9(wheel):
    # name-version-python-abi-platform.whl (PEP 427).
    name, ver, python, abi, platform = wheel.stem.split("-")
    assert (name, python, abi) == ("rmd_rt", "cp39", "abi3"), wheel.name
    assert platform.startswith("manylinux") and platform.endswith("x86_64"), platform
    assert ver == crate_version() == rmd_rt.__version__ == version("rmd-rt")
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        metadata = z.read(f"rmd_rt-{ver}.dist-info/METADATA").decode()
    assert {
        "rmd_rt/__init__.py",
        "rmd_rt/_errors.py",
        "rmd_rt/_bus.py",
        "rmd_rt/_native.pyi",
        "rmd_rt/py.typed",
        "rmd_rt/_native.abi3.so",
    } <= names, names
    assert "Requires-Python: >=3.9" in metadata
    assert re.search(r"(?m)^Requires-Dist: numpy>=1\.23$", metadata), metadata


def test_the_extension_module_is_stripped(wheel, tmp_path):
    readelf = shutil.which("readelf")
    assert readelf, "readelf (binutils, which the Rust toolchain's linker needs) is missing"
    with zipfile.ZipFile(wheel) as z:
        so = Path(z.extract("rmd_rt/_native.abi3.so", tmp_path))
    sections = subprocess.run(
        [readelf, "--section-headers", "--wide", str(so)],
        capture_output=True, text=True, check=True,
    ).stdout
    assert ".text" in sections and ".dynsym" in sections
    for gone in (".symtab", ".strtab", ".debug_info", ".debug_line"):
        assert gone not in sections, gone


def test_the_wheel_installs_into_a_fresh_venv_and_runs_the_example(tmp_path):
    # Offline, from the wheelhouse run.sh filled: the wheel and the NumPy wheel it needs.
    house = env_path("RMD_WHEELHOUSE")
    fresh = tmp_path / "venv"
    venv.create(fresh, with_pip=True)
    python = fresh / "bin" / "python"
    subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
         "--no-index", "--find-links", str(house), "rmd-rt"],
        check=True, timeout=300,
    )
    out = subprocess.run(
        [str(python), str(REPO / "examples" / "python" / "leg4_wave.py"), "--virtual-time",
         "--cycles", "1"],
        capture_output=True, text=True, timeout=300,
        cwd=tmp_path,  # not next to the checkout's python/ sources
    )
    assert out.returncode == 0, out.stderr
    assert "every motor off: True" in out.stdout, out.stdout


def mypy(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", *args], capture_output=True, text=True, timeout=600, cwd=cwd,
    )


def test_the_stubs_match_the_native_module(tmp_path):
    out = mypy(
        "mypy.stubtest", "rmd_rt._native",
        "--allowlist", str(REPO / "tests" / "python" / "stubtest-allowlist.txt"),
        "--mypy-config-file", str(write_mypy_config(tmp_path)),
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.parametrize("target", ["the package", "the example"])
def test_the_package_and_the_example_type_check(tmp_path, target):
    what = {
        "the package": ["-p", "rmd_rt"],
        "the example": [str(REPO / "examples" / "python" / "leg4_wave.py")],
    }[target]
    out = mypy("mypy", "--config-file", str(write_mypy_config(tmp_path)), *what, cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr


def write_mypy_config(tmp_path: Path) -> Path:
    # The cache in the test's own folder, not in the checkout.
    config = tmp_path / "mypy.ini"
    config.write_text(f"[mypy]\ncache_dir = {tmp_path / 'mypy-cache'}\n")
    return config
