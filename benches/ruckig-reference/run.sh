#!/usr/bin/env bash
# Side-by-side calculation time of rmd-traj (ours) and the reference C++ library, ruckig 0.19.4,
# on exactly the same inputs (the ones `cargo bench --bench trajectory` generates).
#
#   benches/ruckig-reference/run.sh [RUNS [SECONDS]]      (defaults: 5 runs, 2 s per benchmark)
#   benches/ruckig-reference/run.sh --callgrind           (instructions per calculation; valgrind)
#
# On a fresh Debian/Ubuntu machine it installs what it misses (g++, python3-pip; valgrind for
# --callgrind), fetches the ruckig 0.19.4 source distribution from PyPI with `pip download`
# (sha256 checked) into target/ruckig-reference/, builds ruckig and harness.cpp with g++ -O3,
# dumps the bench's inputs (RMD_TRAJ_BENCH_DUMP), builds the Rust harness (this directory's crate,
# not a workspace member), then alternates the two binaries RUNS times on fresh1, fresh6,
# repeated1 and repeated6 and prints the mean of the runs' means and the fastest run's mean.
# Not part of CI: it measures, on whatever machine runs it.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
work=$root/target/ruckig-reference
version=0.19.4
sdist=ruckig-$version.tar.gz
sdist_sha256=71d003bf0ff9aa0031d4520b0290a5ffa6458149f5afce8be3ed6d6fba49ea64
benchmarks="fresh1 fresh6 repeated1 repeated6"

callgrind=false
if [ "${1:-}" = --callgrind ]; then
    callgrind=true
    shift
fi
runs=${1:-5}
secs=${2:-2}
case "$runs$secs" in
*[!0-9.]* | "") echo "usage: $0 [RUNS [SECONDS]] | --callgrind" >&2; exit 2 ;;
esac

# --- what the machine needs -------------------------------------------------------------------
missing=()
command -v g++ >/dev/null || missing+=(g++)
python3 -m pip --version >/dev/null 2>&1 || missing+=(python3-pip)
if $callgrind; then command -v valgrind >/dev/null || missing+=(valgrind); fi
if [ ${#missing[@]} -gt 0 ]; then
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo=sudo
    echo "installing ${missing[*]}" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
command -v cargo >/dev/null || { echo "cargo not found: install rustup (rust-toolchain.toml pins the toolchain)" >&2; exit 1; }

mkdir -p "$work"

# --- the reference's sources (PyPI source distribution) ---------------------------------------
src=$work/ruckig-$version
if [ ! -f "$src/include/ruckig/ruckig.hpp" ]; then
    if [ ! -f "$work/$sdist" ]; then
        # Only ruckig as source; pip prepares its metadata, which needs its build backend: take
        # that as wheels (never compiled here).
        python3 -m pip download --quiet --no-deps --only-binary :all: --no-binary ruckig \
            "ruckig==$version" -d "$work"
    fi
    echo "$sdist_sha256  $work/$sdist" | sha256sum --check --quiet
    tar -xzf "$work/$sdist" -C "$work"
fi

# --- the reference harness: ruckig's library sources and harness.cpp, g++ -O3 ------------------
# As ruckig's CMake Release build (-O3 -DNDEBUG, C++20), without its optional cloud client.
ref=$work/harness-ref
if [ ! -x "$ref" ] || [ "$here/harness.cpp" -nt "$ref" ]; then
    echo "building the reference harness (g++ -O3)" >&2
    g++ -O3 -DNDEBUG -std=c++20 -I "$src/include" -o "$ref" "$here/harness.cpp" \
        "$src"/src/ruckig/brake.cpp "$src"/src/ruckig/position_*.cpp "$src"/src/ruckig/velocity_*.cpp
fi

# --- the inputs, written by our criterion bench ------------------------------------------------
inputs=$work/inputs
(cd "$root" && RMD_TRAJ_BENCH_DUMP="$inputs" cargo bench --locked --quiet --bench trajectory >/dev/null)

# --- our harness -------------------------------------------------------------------------------
CARGO_TARGET_DIR=$work/rust cargo build --locked --quiet --release --manifest-path "$here/Cargo.toml"
ours=$work/rust/release/rmd-traj-harness

if $callgrind; then
    cd "$work"
    for b in $benchmarks; do
        n=$(wc -l <"$inputs/$b.txt")
        for side in ours ref; do
            if [ "$side" = ours ]; then bin=$ours toggle='rmd_traj_harness::run*'; else bin=$ref toggle='void run<*'; fi
            valgrind --tool=callgrind --callgrind-out-file="$work/callgrind.$side.$b" \
                --toggle-collect="$toggle" "$bin" "$inputs" 0 "$b" >/dev/null 2>&1
            ir=$(callgrind_annotate "$work/callgrind.$side.$b" 2>/dev/null |
                awk '/PROGRAM TOTALS/ && !done { gsub(",", "", $1); print $1; done = 1 }')
            printf '%-4s %-10s %12s instructions, %8d per calculation (%d inputs)\n' \
                $side "$b" "$ir" $((ir / n)) "$n"
        done
    done
    exit 0
fi

# --- alternated runs ---------------------------------------------------------------------------
log=$work/results.txt
: >"$log"
echo "$runs runs x 4 benchmarks x 2 sides, ${secs} s each (+0.5 s warm-up); raw lines: $log" >&2
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
for i in $(seq "$runs"); do
    for b in $benchmarks; do
        # Alternate which side goes first, so that neither always runs right after the other.
        if [ $((i % 2)) -eq 1 ]; then order="ours ref"; else order="ref ours"; fi
        for side in $order; do
            if [ "$side" = ours ]; then "$ours" "$inputs" "$secs" "$b"; else "$ref" "$inputs" "$secs" "$b"; fi >>"$log"
        done
    done
done
load_after=$(cut -d' ' -f1-3 /proc/loadavg)

echo
echo "ruckig $version (g++ -O3) vs rmd-traj, $runs alternated runs of ${secs} s, mean time per calculation"
echo "load average (1/5/15 min): before $load_before, after $load_after; $(nproc) CPUs"
echo
awk -v order="$benchmarks" '
    # "ours fresh1     mean 0.712 us  median(batch) ..." / "ref fresh1 mean ..."
    { k = $1 " " $2; sum[k] += $4; cnt[k]++; if (!(k in mn) || $4 < mn[k]) mn[k] = $4
      if ($1 == "ours") fail[$2] = $(NF-4) " of " $(NF-2); else nw[$2] = $(NF-5) " of " $(NF-3) }
    END {
        printf "%-10s %12s %10s %12s %10s %10s\n", "benchmark", "ours mean", "ours min", "ref mean", "ref min", "ours/ref"
        n = split(order, names, " ")
        for (i = 1; i <= n; i++) {
            b = names[i]; o = sum["ours " b] / cnt["ours " b]; r = sum["ref " b] / cnt["ref " b]
            printf "%-10s %9.3f µs %7.3f µs %9.3f µs %7.3f µs %10.2f\n", b, o, mn["ours " b], r, mn["ref " b], o / r
        }
        printf "\n(mean: the mean of the per-run means; min: the lowest per-run mean)\n"
        for (i = 1; i <= n; i++) { b = names[i]; printf "%-10s ours failed on %s inputs, ref not Working on %s\n", b, fail[b], nw[b] }
    }' "$log"
