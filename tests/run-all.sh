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

# The Rust tests (unit, integration, property; with `cargo nextest` when it is installed, else
# `cargo test`), built first on a quiet machine, then run once beside every other suite: the doc
# tests; the Python package (built and installed in a venv the script creates, then its pytest
# suite); telemetry against independent readers (Python mcap + mcap-ros2-support, jsonschema, a
# websockets client on loopback, in a venv the script makes; see docs/telemetry.md); the tests
# that need a real Linux CAN stack (natively when this machine has a usable vcan0 and root,
# otherwise in a small qemu VM on Debian's stock kernel that emulates its CPU; see
# docs/socketcan.md); `rmd ros2` against an independent DDS (Cyclone DDS's Python binding, in a
# private network namespace; see docs/ros2.md). Those builds, installs and the emulated VM keep
# every core busy while the Rust tests run: their real-time tests assert only what holds on a
# loaded machine. (`tests/under-load.sh` runs them under a synthetic load of N busy processes
# per core.)
# shellcheck source=tests/workspace-build.sh
source tests/workspace-build.sh
if cargo nextest --version >/dev/null 2>&1; then
  # (Its default filter leaves the kernel test binaries to tests/vcan/run.sh.)
  rust_tests="cargo nextest run ${RMD_WORKSPACE[*]}"
else
  # Without the kernel tests' features (cargo test would run them): a tree of its own.
  rust_tests="cargo test --workspace"
fi
took $rust_tests --no-run
took side_by_side \
  "$rust_tests --no-fail-fast" \
  "cargo test ${RMD_WORKSPACE[*]} --doc" \
  ./tests/python/run.sh \
  ./tests/telemetry/run.sh \
  ./tests/vcan/run.sh \
  ./tests/ros2/run.sh
