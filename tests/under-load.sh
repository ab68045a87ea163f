#!/usr/bin/env bash
# The Rust tests (real-time ones included: the loop on simulated motors in real time, the
# supervisor, signals, the examples, `rmd bench`, `rmd drill`) while every core is busy: one
# busy-looping process per core (or N with --per-core N), at the tests' own priority, as a build
# or a `pip install` beside them would be. A real-time test asserts what must hold on a loaded
# machine, never what only a quiet one gives: this script is how that is checked.
#
# Usage: ./tests/under-load.sh [--per-core N] [extra cargo nextest / cargo test arguments]
#   e.g. ./tests/under-load.sh --per-core 4 -p rmd-loop
set -euo pipefail
cd "$(dirname "$0")/.."

per_core=1
if [[ "${1:-}" == "--per-core" ]]; then
  per_core="$2"
  shift 2
fi
if ! [[ "$per_core" =~ ^[1-9][0-9]*$ ]]; then
  echo "under-load.sh: --per-core takes a whole number of busy processes per core (1 or more)" >&2
  exit 2
fi
scope=("$@")
if [[ ${#scope[@]} -eq 0 ]]; then
  scope=(--workspace)
fi

if cargo nextest --version >/dev/null 2>&1; then
  runner=(cargo nextest run)
else
  runner=(cargo test)
fi

# Built first, on a quiet machine: the load is for the tests, not the compiler.
"${runner[@]}" --no-run "${scope[@]}"

cores=$(nproc)
busy=()
stop_load() {
  for pid in "${busy[@]}"; do
    kill "$pid" 2>/dev/null || true
  done
  wait "${busy[@]}" 2>/dev/null || true
}
trap stop_load EXIT
for _ in $(seq $((cores * per_core))); do
  bash -c 'while :; do :; done' &
  busy+=("$!")
done
echo "under-load.sh: ${#busy[@]} busy processes on $cores cores ($per_core per core)" >&2
sleep 1
echo "under-load.sh: load average $(cut -d' ' -f1-3 /proc/loadavg)" >&2

"${runner[@]}" --no-fail-fast "${scope[@]}"
