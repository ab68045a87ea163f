#!/usr/bin/env bash
# Instructions per tick of the loop alone (docs/benchmarks.md, "Instructions per tick"), counted
# by valgrind's callgrind on the release profile, with the wall-clock time of the same ticks
# beside them.
#
#   benches/tick-instructions.sh            table: instructions and time per tick, 1x4 4x4 8x4
#                                           (multi-torque), 1x3-per-motor 4x3-per-motor
#   benches/tick-instructions.sh --json     one JSON object; its "ir_per_tick" maps 1x4, 4x4
#                                           and 8x4 (and the per-motor configurations) to
#                                           instructions per tick (stable for scripts)
#   benches/tick-instructions.sh --check    the CI gate: fails when a configuration costs more
#                                           than benches/tick-budget.toml allows, or when a
#                                           commit raised the budget without giving a reason
#   --no-time                               skip the wall-clock runs
#   --annotate DIR                          also keep each configuration's 25,000-tick profile
#                                           and its callgrind_annotate breakdown in DIR
#
# How a figure is made, for buses x 4 motors (crates/rmd-tick-bench): the loop is started and
# warmed up for 10,000 ticks (longer than any queue in it: the telemetry mailbox overwrites from
# its 64th sample on, the pending-request rings hold 8), then runs N ticks inside one function,
# `rmd_tick_bench::measured_ticks`, the only code callgrind counts (--toggle-collect). The
# per-motor configurations (buses x 3 MyActuator V3 motors, one 0xA1 request per motor) run in
# the binary's own `measured_ticks_per_motor`. Twice, N = 5,000 and N = 25,000; instructions per
# tick = (Ir(25,000) - Ir(5,000)) / 20,000, so whatever does not repeat every tick cancels.
# Callgrind counts the same instructions for the same binary and input whatever else the machine
# does: the figure is exact on one toolchain.
set -euo pipefail
cd "$(dirname "$0")/.."

# "BxM": B buses of M motors; "-per-motor": on the per-motor exchange (MyActuator V3).
configs=(1x4 4x4 8x4 1x3-per-motor 4x3-per-motor)
warm_up=10000
short=5000
long=25000
budget_file=benches/tick-budget.toml

json=false check=false time=true annotate=""
while (($#)); do
  case "$1" in
    --json) json=true ;;
    --check) check=true ;;
    --no-time) time=false ;;
    --annotate) annotate="${2:?--annotate needs a directory}"; shift ;;
    -h|--help) sed -n '2,26p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "tick-instructions: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done

if ! command -v valgrind >/dev/null; then
  echo "tick-instructions: valgrind is not installed (Debian: apt-get install valgrind)" >&2
  exit 2
fi

log() { if ! $json; then echo "$@" >&2; fi; }

# The budget: `"BxM" = instructions` (or `"BxM-per-motor"`) lines of the [ir_per_tick] table.
budget_of() {
  sed -n "s/^\"$1\"[[:space:]]*=[[:space:]]*\([0-9][0-9]*\).*/\1/p" "$budget_file"
}

# A raise of the budget needs its reason in the commit that made it: a line starting with
# "tick-budget:" in the message. Checked for every commit that touched the file.
check_budget_history() {
  if ! git rev-parse --git-dir >/dev/null 2>&1; then
    echo "tick-instructions: NOTE: not a git checkout: the budget's history was not checked" >&2
    return 0
  fi
  if git rev-parse --is-shallow-repository 2>/dev/null | grep -q true; then
    # The figures themselves are still checked against the budget.
    echo "tick-instructions: NOTE: a shallow clone: the budget's history was not checked (git fetch --unshallow)" >&2
    return 0
  fi
  local bad=0 commit parent key new old
  for commit in $(git log --format=%H -- "$budget_file"); do
    parent=$(git rev-parse -q --verify "$commit^" 2>/dev/null) || continue
    git cat-file -e "$parent:$budget_file" 2>/dev/null || continue
    for key in $(git show "$commit:$budget_file" | sed -n 's/^"\([0-9]*x[0-9]*[a-z-]*\)".*/\1/p'); do
      new=$(git show "$commit:$budget_file" | sed -n "s/^\"$key\"[[:space:]]*=[[:space:]]*\([0-9]*\).*/\1/p")
      old=$(git show "$parent:$budget_file" | sed -n "s/^\"$key\"[[:space:]]*=[[:space:]]*\([0-9]*\).*/\1/p")
      if [[ -n "$old" && -n "$new" && "$new" -gt "$old" ]] &&
        ! git log -1 --format=%B "$commit" | grep -q '^tick-budget:'; then
        echo "tick-instructions: commit ${commit:0:9} raises the $key budget $old -> $new without a 'tick-budget: <reason>' line in its message" >&2
        bad=1
      fi
    done
  done
  return $bad
}

log "building the loop-alone scenario (release profile) ..."
exe=$(cargo build --release --quiet -p rmd-tick-bench --bin tick-instructions \
  --message-format=json-render-diagnostics |
  sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)
if [[ -z "$exe" || ! -x "$exe" ]]; then
  echo "tick-instructions: the build gave no executable" >&2
  exit 1
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# The binary's arguments for configuration $1, and the function callgrind counts.
args_of() {
  case "$1" in
    *-per-motor) echo "--buses ${1%%x*} --exchange per-motor" ;;
    *) echo "--buses ${1%%x*}" ;;
  esac
}
measured_of() {
  case "$1" in
    *-per-motor) echo 'tick_instructions::measured_ticks_per_motor' ;;
    *) echo 'rmd_tick_bench::measured_ticks' ;;
  esac
}

# Instructions counted in the measured function for `ticks` ticks of configuration `name`.
count() {
  local name=$1 ticks=$2 out="$work/callgrind.$1.$2"
  # shellcheck disable=SC2046 # the arguments are words
  valgrind --tool=callgrind --callgrind-out-file="$out" \
    --collect-atstart=no --toggle-collect="$(measured_of "$name")" \
    "$exe" $(args_of "$name") --warm-up "$warm_up" --ticks "$ticks" >"$work/run.$1.$2.log" 2>&1 || {
    cat "$work/run.$1.$2.log" >&2
    echo "tick-instructions: the run of $name, $ticks ticks failed" >&2
    exit 1
  }
  local total
  total=$(sed -n 's/^summary: \([0-9]*\).*/\1/p' "$out")
  if [[ -z "$total" || "$total" -eq 0 ]]; then
    echo "tick-instructions: callgrind counted nothing in measured_ticks ($out)" >&2
    exit 1
  fi
  echo "$total"
}

# Instructions per tick by concern, from callgrind_annotate's self cost per "source file:
# function" (inlined code keeps its own source file): the project's files by what they do,
# the standard library's and other crates' by the function they were inlined into.
breakdown() {
  awk -v ticks="$2" '
    function concern(file, fn) {
      if (file ~ /rmd-tick-bench\/src\/lib.rs/ || fn ~ /Canned(Motor)?Bus/) return "the scenario'"'"'s canned bus"
      if (fn ~ /::publish/) return "telemetry"
      if (file ~ /exchange\/collect.rs|rmd-bus\/src\/(ready|bus).rs/) return "collecting: waits and receives"
      if (file ~ /exchange\/frames.rs|rmd-protocol\//) return "frames: decode and encode"
      if (file ~ /exchange\/(motor|pending).rs|mapping.rs|feedback.rs/) return "reply matching and feedback"
      if (file ~ /exchange\/account.rs/) return "missing replies and temperature"
      if (file ~ /stats.rs|hdrhistogram/) return "statistics (five latency figures)"
      if (file ~ /telemetry\/|crossbeam|mailbox.rs/) return "telemetry"
      if (file ~ /rmd-loop\/src\/|rmd-bus\/src\/|nix-|clock_gettime/) return "tick sequence: schedule, clocks, send, staging, supervisor handshake"
      if (fn ~ /Canned(Motor)?Bus/) return "the scenario'"'"'s canned bus"
      if (fn ~ /collect_all|::receive|wait_any/) return "collecting: waits and receives"
      if (fn ~ /on_reply|end_tick|begin_tick/) return "reply matching and feedback"
      if (fn ~ /::account/) return "missing replies and temperature"
      if (fn ~ /publish|telemetry/) return "telemetry"
      if (fn ~ /stats|Histogram/) return "statistics (five latency figures)"
      if (fn ~ /rmd_protocol/) return "frames: decode and encode"
      return "tick sequence: schedule, clocks, send, staging, supervisor handshake"
    }
    /^ *[0-9,]+ +\([ 0-9.]+%\) +[^ ]/ {
      if ($0 ~ /PROGRAM TOTALS/) next
      count = $1; gsub(",", "", count)
      line = $0; sub(/^ *[0-9,]+ +\([ 0-9.]+%\) +/, "", line)
      split(line, part, ":"); file = part[1]; fn = substr(line, length(file) + 2)
      sum[concern(file, fn)] += count; total += count
    }
    END {
      for (c in sum) printf "%8.0f  %s\n", sum[c] / ticks, c
      printf "%8.0f  total\n", total / ticks
    }' "$1" | sort -rn
}

declare -A ir_short ir_long per_tick ns_min ns_median
for name in "${configs[@]}"; do
  log "counting $name (two runs under callgrind) ..."
  # The two runs side by side (callgrind runs a program on one CPU; what it counts does not
  # depend on what else runs).
  count "$name" "$short" >"$work/ir.short" &
  short_run=$!
  ir_long[$name]=$(count "$name" "$long")
  wait "$short_run"
  ir_short[$name]=$(<"$work/ir.short")
  per_tick[$name]=$(awk -v a="${ir_short[$name]}" -v b="${ir_long[$name]}" -v n=$((long - short)) \
    'BEGIN { printf "%.1f", (b - a) / n }')
  if [[ -n "$annotate" ]]; then
    mkdir -p "$annotate"
    cp "$work/callgrind.$name.$long" "$annotate/callgrind.$name.$long"
    callgrind_annotate --auto=no --threshold=100 --inclusive=no \
      "$annotate/callgrind.$name.$long" >"$annotate/$name.self.txt"
    callgrind_annotate --auto=no --threshold=100 --inclusive=yes \
      "$annotate/callgrind.$name.$long" >"$annotate/$name.inclusive.txt"
    breakdown "$annotate/$name.self.txt" "$long" >"$annotate/$name.concerns.txt"
  fi
  if $time; then
    log "timing $name (native, 7 rounds of $long ticks) ..."
    # shellcheck disable=SC2046 # the arguments are words
    timed=$("$exe" $(args_of "$name") --warm-up "$warm_up" --ticks "$long" --time 7)
    ns_min[$name]=$(sed -n 's/^ns_per_tick_min //p' <<<"$timed")
    ns_median[$name]=$(sed -n 's/^ns_per_tick_median //p' <<<"$timed")
  fi
done

commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
rustc_version=$(rustc --version)

over=0
if $check; then
  for name in "${configs[@]}"; do
    limit=$(budget_of "$name")
    if [[ -z "$limit" ]]; then
      echo "tick-instructions: $budget_file has no budget for $name" >&2
      over=1
    elif awk -v x="${per_tick[$name]}" -v l="$limit" 'BEGIN { exit !(x > l) }'; then
      echo "tick-instructions: $name costs ${per_tick[$name]} instructions per tick, over its budget of $limit ($budget_file)" >&2
      over=1
    fi
  done
  check_budget_history || over=1
fi

if $json; then
  sep=""
  printf '{"commit":"%s","rustc":"%s","warm_up_ticks":%d,"ticks":[%d,%d],"ir_per_tick":{' \
    "$commit" "$rustc_version" "$warm_up" "$short" "$long"
  for name in "${configs[@]}"; do
    printf '%s"%s":%s' "$sep" "$name" "${per_tick[$name]}"; sep=","
  done
  printf '},"ir_total":{'; sep=""
  for name in "${configs[@]}"; do
    printf '%s"%s":{"%d":%s,"%d":%s}' "$sep" "$name" "$short" "${ir_short[$name]}" "$long" "${ir_long[$name]}"
    sep=","
  done
  printf '}'
  if $time; then
    printf ',"ns_per_tick":{'; sep=""
    for name in "${configs[@]}"; do
      printf '%s"%s":{"min":%s,"median":%s}' "$sep" "$name" "${ns_min[$name]}" "${ns_median[$name]}"
      sep=","
    done
    printf '}'
  fi
  printf ',"budget":{'; sep=""
  for name in "${configs[@]}"; do
    printf '%s"%s":%s' "$sep" "$name" "$(budget_of "$name" || true)"; sep=","
  done
  printf '}}\n'
else
  echo "loop alone, instructions per tick (callgrind, release profile, commit $commit, $rustc_version)"
  printf '%-14s %14s %14s %12s %10s' config "Ir($short)" "Ir($long)" "Ir/tick" budget
  if $time; then printf ' %12s %12s' "ns/tick min" "ns/Ir"; fi
  printf '\n'
  for name in "${configs[@]}"; do
    printf '%-14s %14s %14s %12s %10s' "$name" "${ir_short[$name]}" "${ir_long[$name]}" \
      "${per_tick[$name]}" "$(budget_of "$name")"
    if $time; then
      printf ' %12s %12s' "${ns_min[$name]}" \
        "$(awk -v t="${ns_min[$name]}" -v i="${per_tick[$name]}" 'BEGIN { printf "%.3f", t / i }')"
    fi
    printf '\n'
  done
fi
exit $over
