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

# The kernel test suites: `cargo test` selections, one per line. A suite whose package has
# binaries (e.g. the `rmd` CLI) gets them copied into the VM at the same path, so
# CARGO_BIN_EXE_<name> works there too.
SUITES=(
  "-p rmd-bus --features kernel-tests --test socketcan"
  "-p rmd-cli --features kernel-tests --test vcan"
)

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
for suite in "${SUITES[@]}"; do
  # shellcheck disable=SC2086 # the suite is a list of cargo arguments
  json="$(cargo test $suite --no-run --message-format=json-render-diagnostics)"
  tests=()
  bins=()
  while IFS= read -r line; do
    executable="$(sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' <<<"$line")"
    [ -n "$executable" ] || continue
    # The target's kind tells a test harness from a binary (both have `"test":true` in their
    # target, since binaries are testable by default).
    if grep -q '"kind":\["bin"\]' <<<"$line"; then
      bins+=("$executable")
    else
      tests+=("$executable")
    fi
  done < <(grep '"reason":"compiler-artifact"' <<<"$json")
  [ ${#tests[@]} -gt 0 ] || vcan_die "cargo built no test binary for: $suite"

  for test in "${tests[@]}"; do
    vcan_log "$(basename "$test") ($suite)"
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
