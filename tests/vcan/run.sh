#!/usr/bin/env bash
# Builds the SocketCAN kernel tests and runs them against a real Linux CAN stack: natively when
# this machine has a usable vcan0 and may create CAN interfaces (root), otherwise inside a small
# qemu VM booted on Debian's stock kernel (see run-in-vm.sh; first run downloads ~100 MB of
# Debian packages into target/vcan-cache).
#
# Usage: tests/vcan/run.sh [TEST-BINARY ARGS...]     (e.g. a test name filter, --nocapture)
#
# Environment:
#   RMD_VCAN_MODE=auto|native|vm   force where the tests run (default auto)
#   RMD_VCAN_CACHE=DIR             download cache (default target/vcan-cache)
set -euo pipefail
# shellcheck source=tests/vcan/lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
cd "$VCAN_REPO"
# shellcheck source=tests/workspace-build.sh
source tests/workspace-build.sh

# The kernel test suites: a package and its test target. A suite whose package has binaries
# (e.g. the `rmd` CLI) gets them copied into the VM at the same path, so CARGO_BIN_EXE_<name>
# works there too.
SUITES=(
  "rmd-bus socketcan"
  "rmd-cli vcan"
)

# The executables of package $1 (its crates/ folder) that a line of cargo's JSON messages on
# stdin reports: $2 = test, the test target named $3; $2 = bin, its binaries (not their unit-test
# harnesses).
executables() {
  python3 -c '
import json, sys
package, kind, name = sys.argv[1], sys.argv[2], sys.argv[3:]
for line in sys.stdin:
    try:
        m = json.loads(line)
    except ValueError:
        continue
    if m.get("reason") != "compiler-artifact" or not m.get("executable"):
        continue
    if not m["manifest_path"].endswith("/crates/" + package + "/Cargo.toml"):
        continue
    t = m["target"]
    if kind not in t["kind"] or (name and t["name"] != name[0]):
        continue
    if kind == "bin" and m["profile"]["test"]:
        continue
    print(m["executable"])
' "$@"
}

mode="${RMD_VCAN_MODE:-auto}"
if [ "$mode" = auto ]; then
  if vcan_native_ok; then mode=native; else mode=vm; fi
fi
case "$mode" in
  native | vm) ;;
  *) vcan_die "RMD_VCAN_MODE must be auto, native or vm (got $mode)" ;;
esac
vcan_log "running the kernel tests ($mode)"

start=$SECONDS
failed=0
# Built as every test script builds (tests/workspace-build.sh): after the Rust tests' build,
# nothing is compiled again.
json="$(cargo test "${RMD_WORKSPACE[@]}" --no-run --message-format=json-render-diagnostics)"
for suite in "${SUITES[@]}"; do
  read -r package target <<<"$suite"
  mapfile -t tests < <(executables "$package" test "$target" <<<"$json")
  mapfile -t bins < <(executables "$package" bin <<<"$json")
  [ ${#tests[@]} -gt 0 ] || vcan_die "cargo built no test binary $target of $package"

  for test in "${tests[@]}"; do
    vcan_log "$(basename "$test") ($package, test $target)"
    if [ "$mode" = native ]; then
      "$test" "$@" || failed=1
    else
      with=()
      for bin in "${bins[@]}"; do with+=(--with "$bin"); done
      "$VCAN_DIR/run-in-vm.sh" "${with[@]}" -- "$test" "$@" || failed=1
    fi
  done
done
if [ "$failed" -ne 0 ]; then
  vcan_log "kernel tests FAILED ($mode, $((SECONDS - start)) s): see the output above"
else
  vcan_log "kernel tests passed in $((SECONDS - start)) s ($mode)"
fi
exit "$failed"
