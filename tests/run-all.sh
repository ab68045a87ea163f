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
# The Python package: built and installed in a venv the script creates, then its pytest suite.
./tests/python/run.sh
# The tests that need a real Linux CAN stack: natively when this machine has a usable vcan0 and
# root, otherwise in a small qemu VM on Debian's stock kernel (see docs/socketcan.md).
./tests/vcan/run.sh
