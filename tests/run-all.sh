#!/usr/bin/env bash
# The one command that runs every test of rmd-rt (unit, integration, property, doc tests).
# Usage: ./tests/run-all.sh
set -euo pipefail
cd "$(dirname "$0")/.."

if cargo nextest --version >/dev/null 2>&1; then
  cargo nextest run --workspace --no-fail-fast
else
  cargo test --workspace --no-fail-fast
fi
# nextest does not run doc tests.
cargo test --workspace --doc
# The Rust tests again with every core busy: the real-time ones must hold on a loaded machine.
./tests/under-load.sh
# The Python package: built and installed in a venv the script creates, then its pytest suite.
./tests/python/run.sh
# Telemetry against independent readers (Python mcap + mcap-ros2-support, jsonschema, a
# websockets client on loopback), installed by the script into a venv (see docs/telemetry.md).
./tests/telemetry/run.sh
# The tests that need a real Linux CAN stack: natively when this machine has a usable vcan0 and
# root, otherwise in a small qemu VM on Debian's stock kernel (see docs/socketcan.md).
./tests/vcan/run.sh
# `rmd ros2` against an independent DDS (Cyclone DDS's Python binding, in a venv the script
# makes), in a private network namespace (see docs/ros2.md).
./tests/ros2/run.sh
