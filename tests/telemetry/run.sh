#!/usr/bin/env bash
# The telemetry tests against independent implementations: the Python `mcap` and
# `mcap-ros2-support` readers (MCAP files, also truncated ones), `jsonschema` (the JSON channels),
# `websockets` speaking the Foxglove WebSocket protocol (the live server). Installs them, pinned,
# into a venv under target/, builds the synthetic writer (the `telemetry_synth` example of
# rmd-telemetry), the `rmd` tool (`rmd bench loop --mcap/--foxglove`, `rmd decode --mcap`,
# `rmd torque --mcap`, `rmd drill`, `rmd replay`) and the `pd_hold` example, and runs pytest.
# The full-disk tests mount a small tmpfs in a private mount namespace (`unshare -m`, as root). Loopback only. Idempotent: the venv is rebuilt only when
# requirements.txt changes.
# Usage: ./tests/telemetry/run.sh [pytest args...]
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=tests/workspace-build.sh
source tests/workspace-build.sh

target_dir="${CARGO_TARGET_DIR:-target}"
case "$target_dir" in /*) ;; *) target_dir="$PWD/$target_dir" ;; esac
venv="$target_dir/telemetry-venv"
requirements=tests/telemetry/requirements.txt

if ! [ -x "$venv/bin/python" ] || ! cmp -s "$requirements" "$venv/requirements.txt"; then
  echo "telemetry tests: installing the pinned Python readers into $venv"
  python3 -m venv --clear "$venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-input \
    --requirement "$requirements"
  cp "$requirements" "$venv/requirements.txt"
fi

cargo build --quiet "${RMD_WORKSPACE[@]}" --bins --examples
export TELEMETRY_SYNTH="$target_dir/debug/examples/telemetry_synth"
export RMD_BIN="$target_dir/debug/rmd"
export PD_HOLD_BIN="$target_dir/debug/examples/pd_hold"
test -x "$TELEMETRY_SYNTH"
test -x "$RMD_BIN"
test -x "$PD_HOLD_BIN"

exec "$venv/bin/python" -m pytest -p no:cacheprovider -q tests/telemetry "$@"
