#!/usr/bin/env bash
# Wake latency of rmd-rt's loop timer, side by side with cyclictest, in one session.
#
# Runs, alternately and for several rounds, at the same period, SCHED_FIFO priority and CPU:
#   1. cyclictest -m -p PRIO -a CPU -i PERIOD -D SECONDS -h HIST -q     (the kernel's timer)
#   2. rmd bench jitter --fifo PRIO --cpu CPU --period-us PERIOD            (sleep only)
#   3. rmd bench jitter ... --spin-us SPIN                                 (sleep, then spin)
# (the order rotates every round), then prints a table of the three with ratios to cyclictest
# (examples/jitter_compare.rs: pooled 1-us histograms, one percentile rule for all) and draws
# their histograms as an SVG.
#
# Usage: benches/jitter-vs-cyclictest.sh [--rounds N] [--seconds S] [--period-us P] [--prio PRIO]
#                                        [--cpu C] [--spin-us U] [--out DIR] [--svg FILE]
#                                        [--markdown FILE] [--json FILE] [--note TEXT]
# Defaults: 3 rounds of 30 s per tool, 1000 us, priority 80, CPU 1, spin 50 us,
#           results in target/jitter-vs-cyclictest/, plot in DIR/jitter-histograms.svg;
#           --markdown / --json: the table as Markdown / the ratios as JSON, too;
#           --note: appended to the plot's caption.
#
# Needs root (SCHED_FIFO, mlockall, /dev/cpu_dma_latency, and apt-get to install Debian's
# rt-tests when cyclictest is missing). Each tool holds /dev/cpu_dma_latency at 0 itself while
# it runs, with its defaults: cyclictest always, rmd bench jitter because --cpu / --fifo are
# given (the loop's own setting; its real-time line, logged in DIR/machine.txt, says whether it
# was held). The script does not hold it.
set -euo pipefail
cd "$(dirname "$0")/.."

rounds=3
seconds=30
period_us=1000
prio=80
cpu=1
spin_us=50
out=target/jitter-vs-cyclictest
svg=
markdown=
json=
note=
hist_us=10000

die() { echo "error: $*" >&2; exit 2; }
int() { [[ "$2" =~ ^[0-9]+$ ]] || die "$1 needs a whole number, got '$2'"; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    --rounds) int "$1" "${2-}"; rounds=$2; shift 2 ;;
    --seconds) int "$1" "${2-}"; seconds=$2; shift 2 ;;
    --period-us) int "$1" "${2-}"; period_us=$2; shift 2 ;;
    --prio) int "$1" "${2-}"; prio=$2; shift 2 ;;
    --cpu) int "$1" "${2-}"; cpu=$2; shift 2 ;;
    --spin-us) int "$1" "${2-}"; spin_us=$2; shift 2 ;;
    --out) out=${2-}; shift 2 ;;
    --svg) svg=${2-}; shift 2 ;;
    --markdown) markdown=${2-}; shift 2 ;;
    --json) json=${2-}; shift 2 ;;
    --note) note=${2-}; shift 2 ;;
    -h|--help) awk 'NR > 1 { if (!/^#/) exit; sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
[[ $rounds -ge 1 && $seconds -ge 1 ]] || die "--rounds and --seconds must be at least 1"
[[ $prio -ge 1 && $prio -le 99 ]] || die "--prio must be 1..99"
svg=${svg:-$out/jitter-histograms.svg}

if [[ $(id -u) -ne 0 ]]; then
  echo "warning: not root: SCHED_FIFO, mlockall and /dev/cpu_dma_latency may be refused" >&2
fi

if ! command -v cyclictest >/dev/null 2>&1; then
  echo "cyclictest not found: installing Debian's rt-tests" >&2
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q rt-tests
fi

echo "building rmd and the comparison tool (release)" >&2
cargo build --locked --release -q -p rmd-cli
cargo build --locked --release -q --example jitter_compare
rmd=target/release/rmd
compare=target/release/examples/jitter_compare

mkdir -p "$out"
rm -f "$out"/round-*

{
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "kernel: $(uname -srv)"
  lscpu | grep -E '^(Model name|CPU\(s\)|Thread\(s\) per core|Hypervisor vendor|Virtualization type):' \
    | sed 's/  */ /g'
  echo "clocksource: $(cat /sys/devices/system/clocksource/clocksource0/current_clocksource 2>/dev/null || echo unknown)"
  echo "cpuidle driver: $(cat /sys/devices/system/cpu/cpuidle/current_driver 2>/dev/null || echo none)"
  echo "cpu_dma_latency: held at 0 us by each tool while it runs (not by this script)"
  echo "rt-tests: $(dpkg-query -W -f '${Version}' rt-tests 2>/dev/null || echo unknown)"
  echo "rmd: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (modified)')"
  echo "set-up: period ${period_us} us, SCHED_FIFO ${prio}, CPU ${cpu}, ${rounds} round(s) x ${seconds} s per tool, spin margin ${spin_us} us"
  echo "load before: $(cat /proc/loadavg)"
} > "$out/machine.txt"
cat "$out/machine.txt"

run_cyclictest() {
  cyclictest -m -p "$prio" -a "$cpu" -i "$period_us" -D "$seconds" -h "$hist_us" -q \
    > "$out/round-$1-cyclictest.txt"
}
run_sleep() {
  "$rmd" bench jitter --period-us "$period_us" --seconds "$seconds" --cpu "$cpu" --fifo "$prio" \
    --json > "$out/round-$1-rmd-sleep.json"
}
run_spin() {
  "$rmd" bench jitter --period-us "$period_us" --seconds "$seconds" --cpu "$cpu" --fifo "$prio" \
    --spin-us "$spin_us" --json > "$out/round-$1-rmd-spin.json"
}

tools=(run_cyclictest run_sleep run_spin)
for ((r = 1; r <= rounds; r++)); do
  for ((i = 0; i < 3; i++)); do
    tool=${tools[$(((r - 1 + i) % 3))]}
    echo "round $r/$rounds: ${tool#run_} (${seconds} s), load $(cut -d' ' -f1-3 /proc/loadavg)" >&2
    "$tool" "$r"
  done
done
echo "load after: $(cat /proc/loadavg)" | tee -a "$out/machine.txt"

echo "rmd real-time setup (round 1, sleep only): $(sed -n 's/.*"realtime":"\([^"]*\)".*/\1/p' "$out/round-1-rmd-sleep.json")" \
  | tee -a "$out/machine.txt"

caption="wake latency, ${period_us} us period, SCHED_FIFO ${prio}, CPU ${cpu}, ${rounds} x ${seconds} s each (spin ${spin_us} us)${note}"
extra=()
[[ -n $markdown ]] && extra+=(--markdown "$markdown")
[[ -n $json ]] && extra+=(--json "$json")
"$compare" "$out" --svg "$svg" --caption "$caption" "${extra[@]}" | tee "$out/summary.txt"
