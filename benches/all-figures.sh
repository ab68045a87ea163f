#!/usr/bin/env bash
# Regenerates every figure of docs/benchmarks.md in one run, writes them into its generated
# blocks (<!-- figures:NAME --> ... <!-- /figures:NAME -->) and draws the plots in docs/img/:
#   1. cargo bench --bench tick               tick overhead, allocations per tick, and its
#      benches/tick-instructions.sh           instructions per tick (callgrind) beside it
#   2. benches/jitter-vs-cyclictest.sh        wake latency vs cyclictest (its defaults), plot
#   3. rmd bench rate --buses 1,2,4,8         headline and zero-miss rates against the wire
#                                              limit, loop added time; polling receive, then
#                                              blocking receive on 1 and 4 buses; plot
#   4. rmd bench loop --buses 1 and 4         the loop report at 1 kHz
#   5. cargo bench --bench protocol, --bench trajectory, -p rmd-sim --bench exchange
#                                              (the other costs; the comparison with ruckig
#                                              has its own script, benches/ruckig-reference/)
#   6. the summary table (issue 17's goals), from the outputs of 1-3
# with the machine (CPU, kernel, clock source, rustc, rt-tests) and the load average before
# each figure recorded. Raw outputs go to target/figures/ (or --out).
#
# Nothing tracked changes unless --write-docs is given: without it the page with the new blocks
# is OUT/benchmarks.md and the plots are in OUT/img/ (compare them with the docs, then rerun
# with --write-docs, or copy them over). Cargo runs with --locked (Cargo.lock is never rewritten).
#
# Usage: benches/all-figures.sh [--smoke] [--write-docs] [--quiet-load L] [--max-wait S]
#                               [--cpu C] [--prio P] [--doc FILE] [--img-dir DIR] [--out DIR]
#   --smoke         very short runs (1 s jitter rounds, 0.3 s rate trials, ...) to test the
#                   script, without waiting for a quiet machine: every block says "smoke, not
#                   headline" (1 to 3 minutes once everything is built)
#   --write-docs    write the blocks into --doc and the plots into --img-dir (tracked files)
#   --quiet-load L  before each figure, wait until the 1-minute load average is below L
#                   (default 0.5, with --smoke 0; 0 disables the wait)
#   --max-wait S    stop waiting S seconds after the start (for all figures together) and run
#                   the rest anyway, saying so in the notes (default 1800)
#   --cpu C         the loop's CPU (default 1; the simulators run on another one)
#   --prio P        SCHED_FIFO priority of the loop and cyclictest (default 80)
#   --doc FILE      the document whose blocks to fill (default docs/benchmarks.md)
#   --img-dir DIR   where the SVG plots go (default OUT/img; with --write-docs docs/img)
#
# Fresh machine: needs Rust (rustup; rust-toolchain.toml picks the version) and, for
# cyclictest, Debian's rt-tests, which this script installs with apt-get when it is missing.
# Run as root (SCHED_FIFO, mlockall, /dev/cpu_dma_latency, apt-get), on an otherwise idle
# machine: timing figures need the load average well below 1. Plots are drawn by the
# examples jitter_compare and bench_figures (the plotters crate: nothing to install).
set -euo pipefail
cd "$(dirname "$0")/.."

smoke=0
write_docs=0
quiet_load=
max_wait=1800
cpu=1
prio=80
doc=docs/benchmarks.md
img=
out=target/figures

die() { echo "error: $*" >&2; exit 2; }
while [[ $# -gt 0 ]]; do
  case "$1" in
    --smoke) smoke=1; shift ;;
    --write-docs) write_docs=1; shift ;;
    --quiet-load) quiet_load=${2-}; shift 2 ;;
    --max-wait) max_wait=${2-}; shift 2 ;;
    --cpu) cpu=${2-}; shift 2 ;;
    --prio) prio=${2-}; shift 2 ;;
    --doc) doc=${2-}; shift 2 ;;
    --img-dir) img=${2-}; shift 2 ;;
    --out) out=${2-}; shift 2 ;;
    -h|--help) awk 'NR > 1 { if (!/^#/) exit; sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
[[ -f $doc ]] || die "$doc not found"
# A smoke run tests the script: it does not wait for a quiet machine unless asked.
[[ -n $quiet_load ]] || { [[ $smoke -eq 1 ]] && quiet_load=0 || quiet_load=0.5; }
if [[ -z $img ]]; then
  if [[ $write_docs -eq 1 ]]; then img=docs/img; else img=$out/img; fi
fi

if [[ $smoke -eq 1 ]]; then
  jitter_rounds=1; jitter_seconds=1
  rate_duration=300ms; rate_resolution=2; rate_confirm=0
  loop_duration=500ms
  tick_args=(--warm-up-time 0.2 --measurement-time 0.5)
  label="smoke, not headline: very short runs to test benches/all-figures.sh; rerun it without --smoke on a quiet machine"
  tag=" (smoke, not headline)"
else
  jitter_rounds=6; jitter_seconds=30
  rate_duration=10s; rate_resolution=0.5; rate_confirm=1
  loop_duration=10s
  tick_args=()
  label="headline figures"
  tag=""
fi

command -v cargo >/dev/null 2>&1 || die "cargo not found: install Rust with rustup (https://rustup.rs)"
if [[ $(id -u) -ne 0 ]]; then
  echo "warning: not root: SCHED_FIFO, mlockall, /dev/cpu_dma_latency and apt-get may be refused" >&2
fi
if ! command -v cyclictest >/dev/null 2>&1; then
  echo "cyclictest not found: installing Debian's rt-tests" >&2
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q rt-tests
fi

mkdir -p "$out" "$img"
: > "$out/notes.txt"
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
stamp() { echo "- $1: $(date -u +%H:%M:%SZ), load average $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$out/notes.txt"; }

echo "building (release): rmd, jitter_compare, bench_figures" >&2
cargo build --locked --release -q -p rmd-cli
cargo build --locked --release -q --example jitter_compare --example bench_figures
rmd=target/release/rmd
figures=target/release/examples/bench_figures

{
  echo "- date: $(date -u +%Y-%m-%dT%H:%M:%SZ), commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (modified)')"
  echo "- kernel: $(uname -srv)"
  echo "- CPU: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) CPU(s), $(lscpu | sed -n 's/^Thread(s) per core: */threads per core: /p'), hypervisor: $(lscpu | sed -n 's/^Hypervisor vendor: *//p' | grep . || echo none)"
  echo "- clock source: $(cat /sys/devices/system/clocksource/clocksource0/current_clocksource 2>/dev/null || echo unknown); cpuidle driver: $(cat /sys/devices/system/cpu/cpuidle/current_driver 2>/dev/null || echo none)"
  echo "- $(rustc -V); rt-tests $(dpkg-query -W -f '${Version}' rt-tests 2>/dev/null || echo unknown)"
  echo "- set-up: loop on CPU ${cpu} at SCHED_FIFO ${prio}, simulated buses on their own threads on another CPU; ${label}"
  echo "- load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
} > "$out/machine.md"
cat "$out/machine.md"

# From here on a figure that fails (e.g. no rate within the budget) must not stop the others;
# each failure is noted (in the machine block too) and the script exits 1 at the end.
set +e
failed=()
check() { local status=$1 what=$2; [[ $status -eq 0 ]] || { failed+=("$what (exit $status)"); echo "FAILED: $what (exit $status)" | tee -a "$out/notes.txt" >&2; }; }

wait_quiet; stamp "tick overhead"
cargo bench --locked --bench tick -- "${tick_args[@]}" 2>&1 | tee "$out/tick.txt"; check $? "cargo bench --bench tick"
# The same ticks' instructions (callgrind: deterministic), for the time per instruction.
benches/tick-instructions.sh --json --no-time > "$out/tick-instructions.json"; check $? "tick-instructions.sh"
"$figures" tick target/criterion "$out/tick.txt" "$out/tick-instructions.json" > "$out/tick.md"

wait_quiet; stamp "wake latency vs cyclictest"
benches/jitter-vs-cyclictest.sh --rounds "$jitter_rounds" --seconds "$jitter_seconds" --period-us 1000 \
  --prio "$prio" --cpu "$cpu" --spin-us 100 --out "$out/jitter" --svg "$img/jitter-histograms.svg" \
  --markdown "$out/jitter.md" --json "$out/jitter.json" --note "$tag" 2>&1 | tee "$out/jitter.txt"; check $? "jitter-vs-cyclictest.sh"

rate_flags=(--duration "$rate_duration" --cpu "$cpu" --fifo "$prio" --spin-us 100
  --resolution-pct "$rate_resolution" --confirm "$rate_confirm" --json)
wait_quiet; stamp "rate by bus count, polling receive (150 us)"
"$rmd" bench rate --buses 1,2,4,8 --rx-spin-us 150 "${rate_flags[@]}" > "$out/rate.jsonl" 2> "$out/rate.log"; check $? "rmd bench rate (polling)"
"$figures" rate "$out/rate.jsonl" --svg "$img/rate-vs-wire-limit.svg" \
  --caption "highest rate vs the wire limit, 4 motors per bus, polling receive$tag" > "$out/rate.md"
wait_quiet; stamp "rate by bus count, blocking receive"
"$rmd" bench rate --buses 1,4 --rx-spin-us 0 "${rate_flags[@]}" > "$out/rate-blocking.jsonl" 2> "$out/rate-blocking.log"; check $? "rmd bench rate (blocking)"
"$figures" rate "$out/rate-blocking.jsonl" > "$out/rate-blocking.md"

for buses in 1 4; do
  wait_quiet; stamp "loop report, 4 motors x $buses bus(es)"
  "$rmd" bench loop --motors 4 --buses "$buses" --rate 1000 --duration "$loop_duration" --cpu "$cpu" \
    --fifo "$prio" --spin-us 100 --json > "$out/loop-$buses.json"; check $? "rmd bench loop --buses $buses"
done
"$figures" loop "$out/loop-1.json" "$out/loop-4.json" > "$out/loop.md"

wait_quiet; stamp "protocol, trajectory and simulator costs"
for bench in "--bench protocol" "--bench trajectory" "-p rmd-sim --bench exchange"; do
  # shellcheck disable=SC2086 # two words each, on purpose
  cargo bench --locked $bench -- "${tick_args[@]}" 2>&1 | tee -a "$out/other.txt"; check $? "cargo bench $bench"
done
"$figures" criterion target/criterion "encode" "decode" "calculate" "sample" "simbus" "simmotors" \
  > "$out/other.md"

"$figures" summary --tick target/criterion --tick-log "$out/tick.txt" --jitter "$out/jitter.json" \
  --rate "$out/rate.jsonl" > "$out/summary.md"
stamp "done"
set -e

# The page the blocks go into: the document itself with --write-docs, else a copy in $out.
page=$doc
if [[ $write_docs -eq 0 ]]; then
  page=$out/$(basename "$doc")
  cp "$doc" "$page"
fi
# Each generated block: the label, then the table.
put_block() {
  local name=$1 body=$2
  grep -qx "<!-- figures:$name -->" "$page" || die "$doc has no <!-- figures:$name --> block"
  { echo "_${label}._"; echo; cat "$body"; } > "$out/block-$name.md"
  awk -v begin="<!-- figures:$name -->" -v end="<!-- /figures:$name -->" -v file="$out/block-$name.md" '
    $0 == begin { print; while ((getline line < file) > 0) print line; skip = 1; next }
    $0 == end { skip = 0 }
    !skip { print }' "$page" > "$page.tmp"
  mv "$page.tmp" "$page"
}
cat "$out/machine.md" "$out/notes.txt" > "$out/machine-and-load.md"
put_block machine "$out/machine-and-load.md"
put_block summary "$out/summary.md"
put_block tick "$out/tick.md"
put_block jitter "$out/jitter.md"
put_block rate "$out/rate.md"
put_block rate-blocking "$out/rate-blocking.md"
put_block loop "$out/loop.md"
put_block other "$out/other.md"
echo "wrote $page, $img/jitter-histograms.svg and $img/rate-vs-wire-limit.svg (raw outputs in $out/)"
if [[ $write_docs -eq 0 ]]; then
  echo "$doc and docs/img are unchanged: compare (diff $doc $page), then rerun with --write-docs to write them"
fi
if [[ ${#failed[@]} -gt 0 ]]; then
  echo "error: ${#failed[@]} figure(s) failed (noted in the machine block): ${failed[*]}" >&2
  exit 1
fi
