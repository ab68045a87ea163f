#!/usr/bin/env bash
# Re-runs every figure of docs/benchmarks.md, in order, with the machine's state before each:
#   1. cargo bench --bench tick                          (tick overhead, allocations per tick)
#   2. benches/jitter-vs-cyclictest.sh                   (wake latency vs cyclictest, plot)
#   3. rmd bench rate --buses 1 and --buses 4, blocking and polling receive (--rx-spin-us 50)
#                                                         (bus-limited rate vs the wire limit)
#      and one trial each at 1165 Hz (95% of the wire limit)
#   4. rmd bench loop, 4 motors and 4 x 4 motors at 1 kHz (the loop report)
# Logs go to target/figures/; the plot to docs/img/jitter-histograms.svg.
#
# Usage: benches/all-figures.sh [--quiet-load L] [--max-wait S]
#   --quiet-load L  before each figure, wait until the 1-minute load average is below L
#                   (default 0.5; 0 disables the wait)
#   --max-wait S    stop waiting S seconds after the start (for all figures together) and run
#                   the rest anyway, saying so (default 1800)
# Needs root (SCHED_FIFO, mlockall, cyclictest). Timing figures need a quiet machine: nothing
# else running, the load average well below 1.
set -euo pipefail
cd "$(dirname "$0")/.."

quiet_load=0.5
max_wait=1800
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quiet-load) quiet_load=${2-}; shift 2 ;;
    --max-wait) max_wait=${2-}; shift 2 ;;
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "error: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

out=target/figures
mkdir -p "$out" docs/img

give_up_at=$((SECONDS + max_wait))
wait_quiet() {
  while awk -v l="$quiet_load" '{ exit !(l > 0 && $1 >= l) }' /proc/loadavg; do
    if [[ $SECONDS -ge $give_up_at ]]; then
      echo "WARNING: load $(cut -d' ' -f1-3 /proc/loadavg), not below ${quiet_load}: this figure is provisional" \
        | tee -a "$out/notes.txt" >&2
      return
    fi
    sleep 10
  done
}

stamp() { echo "== $1: $(date -u +%H:%M:%SZ), load $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$out/notes.txt"; }

: > "$out/notes.txt"
{
  uname -srv
  lscpu | grep -E '^(Model name|CPU\(s\)|Thread\(s\) per core|Hypervisor vendor):' | sed 's/  */ /g'
  git rev-parse --short HEAD
} | tee -a "$out/notes.txt"

cargo build --release -q -p rmd-cli
rmd=target/release/rmd
# From here on a figure that fails (e.g. no rate passed) must not stop the others.
set +e

wait_quiet; stamp "tick overhead"
cargo bench --bench tick 2>&1 | tee "$out/tick.txt"

wait_quiet; stamp "jitter vs cyclictest"
benches/jitter-vs-cyclictest.sh --rounds 6 --seconds 30 --period-us 1000 --prio 80 --cpu 1 \
  --spin-us 100 --out "$out/jitter" --svg docs/img/jitter-histograms.svg 2>&1 | tee "$out/jitter.txt"

for rx in 0 50; do
  for buses in 1 4; do
    wait_quiet; stamp "rate, $buses bus(es), rx spin $rx us"
    "$rmd" bench rate --buses "$buses" --seconds 10 --cpu 1 --fifo 80 --spin-us 100 --rx-spin-us "$rx" 2>&1 \
      | tee "$out/rate-$buses-rx$rx.txt"
  done
done

# One trial each at 95% of the wire limit (about 1225 Hz): how many ticks miss there.
for buses in 1 4; do
  wait_quiet; stamp "rate 1165 Hz, $buses bus(es), rx spin 50 us"
  "$rmd" bench rate --buses "$buses" --rate 1165 --seconds 10 --cpu 1 --fifo 80 --spin-us 100 \
    --rx-spin-us 50 2>&1 | tee "$out/rate-$buses-1165.txt"
done

for buses in 1 4; do
  wait_quiet; stamp "loop report, 4 motors x $buses bus(es)"
  "$rmd" bench loop --motors 4 --buses "$buses" --rate 1000 --seconds 10 --cpu 1 --fifo 80 \
    --spin-us 100 | tee "$out/loop-$buses.txt"
done
stamp "done"
