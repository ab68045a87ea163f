#!/usr/bin/env bash
# The one command that runs every test of rmd-rt (unit, integration, property, doc tests).
# Usage: ./tests/run-all.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# Each step says how long it took (stderr).
took() {
  local started=$SECONDS
  "$@"
  echo "run-all: $((SECONDS - started)) s for: $*" >&2
}

# Runs the given steps (each a command line) side by side, each into a log of its own; prints
# each step's log, in the order given, once it ended; fails if any step failed. They share the
# cargo build directory (cargo locks it: their builds take turns) and apt (every apt-get of the
# test scripts holds /tmp/rmd-apt.lock); their venvs, VM and network namespaces are their own.
side_by_side() {
  local logs step i=0 failed=0 pids=()
  logs="$(mktemp -d)"
  for step in "$@"; do
    (
      started=$SECONDS
      rc=0
      # shellcheck disable=SC2086 # a step is a command line
      $step >"$logs/$i" 2>&1 </dev/null || rc=$?
      echo "run-all: $((SECONDS - started)) s for: $step (side by side)" >>"$logs/$i"
      exit "$rc"
    ) &
    pids+=("$!")
    i=$((i + 1))
  done
  i=0
  for step in "$@"; do
    if ! wait "${pids[$i]}"; then
      failed=1
      echo "run-all: FAILED: $step" >>"$logs/$i"
    fi
    cat "$logs/$i" >&2
    i=$((i + 1))
  done
  rm -rf "$logs"
  return "$failed"
}

# The Rust tests (unit, integration, property), once, with every core busy: the real-time ones
# must hold on a loaded machine, the stricter test of timing (with `cargo nextest`
# when it is installed, else `cargo test`).
took ./tests/under-load.sh
# Then, side by side (each holds on a loaded machine, and most of each is waiting: on a VM, a
# network, a 10 Hz loop):
# - the doc tests (nextest does not run them);
# - the Python package: built and installed in a venv the script creates, then its pytest suite;
# - telemetry against independent readers (Python mcap + mcap-ros2-support, jsonschema, a
#   websockets client on loopback), installed by the script into a venv (see docs/telemetry.md);
# - the tests that need a real Linux CAN stack: natively when this machine has a usable vcan0 and
#   root, otherwise in a small qemu VM on Debian's stock kernel (see docs/socketcan.md);
# - `rmd ros2` against an independent DDS (Cyclone DDS's Python binding, in a venv the script
#   makes), in a private network namespace (see docs/ros2.md).
took side_by_side \
  "cargo test --workspace --doc" \
  ./tests/python/run.sh \
  ./tests/telemetry/run.sh \
  ./tests/vcan/run.sh \
  ./tests/ros2/run.sh
