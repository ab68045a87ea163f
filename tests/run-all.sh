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

# The Rust tests (unit, integration, property), once, with every core busy: the real-time ones
# must hold on a loaded machine, the stricter test of timing (with `cargo nextest`
# when it is installed, else `cargo test`).
took ./tests/under-load.sh
# nextest does not run doc tests.
took cargo test --workspace --doc
# The Python package: built and installed in a venv the script creates, then its pytest suite.
took ./tests/python/run.sh
# Telemetry against independent readers (Python mcap + mcap-ros2-support, jsonschema, a
# websockets client on loopback), installed by the script into a venv (see docs/telemetry.md).
took ./tests/telemetry/run.sh
# The tests that need a real Linux CAN stack: natively when this machine has a usable vcan0 and
# root, otherwise in a small qemu VM on Debian's stock kernel (see docs/socketcan.md).
took ./tests/vcan/run.sh
# `rmd ros2` against an independent DDS (Cyclone DDS's Python binding, in a venv the script
# makes), in a private network namespace (see docs/ros2.md).
took ./tests/ros2/run.sh
