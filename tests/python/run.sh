#!/usr/bin/env bash
# The Python package's tests: creates a venv under target/, installs the pinned build backend
# and test tools from PyPI (maturin, pytest, NumPy, and the `mcap` reader and `websockets` as
# independent checks of the telemetry), builds and installs the package the way a user does
# (`pip install ./crates/rmd-py`, maturin as the PEP 517 backend), builds the `rmd` tool for the
# parity tests, and runs pytest on crates/rmd-py/tests. Loopback only. The venv is rebuilt only
# when requirements.txt changes; the package is rebuilt on every run.
#
# The package is built with cargo's dev profile (MATURIN_PEP517_ARGS below) so that it reuses
# the workspace's debug build; `pip install ./crates/rmd-py` without it builds a release.
# Usage: ./tests/python/run.sh [pytest args...]
set -euo pipefail
cd "$(dirname "$0")/../.."

target_dir="${CARGO_TARGET_DIR:-target}"
case "$target_dir" in /*) ;; *) target_dir="$PWD/$target_dir" ;; esac
venv="$target_dir/python-venv"
requirements=tests/python/requirements.txt

if ! [ -x "$venv/bin/python" ] || ! cmp -s "$requirements" "$venv/requirements.txt"; then
  echo "python tests: installing the pinned build backend and test tools into $venv"
  python3 -m venv --clear "$venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-input \
    --requirement "$requirements"
  cp "$requirements" "$venv/requirements.txt"
fi

cargo build --quiet -p rmd-cli
export RMD_BIN="$target_dir/debug/rmd"
test -x "$RMD_BIN"

echo "python tests: building and installing ./crates/rmd-py"
# The build backend (maturin) runs from the venv; --no-build-isolation uses the pinned one.
PATH="$venv/bin:$PATH" MATURIN_PEP517_ARGS="--profile dev" \
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-input \
  --no-build-isolation --no-deps --force-reinstall ./crates/rmd-py

cd crates/rmd-py/tests
exec "$venv/bin/python" -m pytest -p no:cacheprovider -q . "$@"
