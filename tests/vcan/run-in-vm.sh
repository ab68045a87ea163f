#!/usr/bin/env bash
# Runs a program inside a small qemu VM booted on a stock Debian kernel with real SocketCAN
# (can, can-raw, can-dev, vcan, slcan modules; vcan0 created and up), and exits with the
# program's exit status.
#
# Usage: tests/vcan/run-in-vm.sh [--with FILE]... [--timeout SECONDS] [--] PROGRAM [ARGS...]
#
#   --with FILE   also copy the executable FILE (and its libraries) into the VM, at the same
#                 absolute path (so paths such as CARGO_BIN_EXE_<name> work unchanged).
#   --timeout S   give up after S seconds (default 600).
#
# It works as a cargo target runner:
#   CARGO_TARGET_X86_64_UNKNOWN_LINUX_GNU_RUNNER="$PWD/tests/vcan/run-in-vm.sh" \
#     cargo test -p rmd-bus --features kernel-tests --test socketcan
#
# Environment passed into the VM: RUST_BACKTRACE, RUST_TEST_THREADS, RUST_LOG, NO_COLOR and
# every RMD_* variable. The program runs as root in /tmp; PATH holds busybox (ip, tc, ...).
# Downloads (first run only) are cached; see lib.sh.
set -euo pipefail
# shellcheck source=tests/vcan/lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

extra=()
timeout_s=600
while [ $# -gt 0 ]; do
  case "$1" in
    --with) extra+=("$2"); shift 2 ;;
    --timeout) timeout_s="$2"; shift 2 ;;
    --) shift; break ;;
    -*) vcan_die "unknown option $1" ;;
    *) break ;;
  esac
done
[ $# -ge 1 ] || vcan_die "usage: run-in-vm.sh [--with FILE]... [--timeout S] [--] PROGRAM [ARGS...]"
program="$(readlink -f "$1")"
shift
[ -x "$program" ] || vcan_die "$program is not an executable"

vcan_fetch

work="$(mktemp -d "${TMPDIR:-/tmp}/rmd-vm.XXXXXX")"
trap 'rm -rf "$work"' EXIT
root="$work/root"
mkdir -p "$root"/{bin,dev,proc,sys,tmp,rmd/modules}
cp "$VCAN_CACHE/tools/root/bin/busybox" "$root/bin/busybox"
cp "$VCAN_DIR/init.sh" "$root/init"
chmod +x "$root/init"
for module in "${VCAN_MODULES[@]}"; do
  cp "$VCAN_CACHE/kernel/modules/$(basename "$module")" "$root/rmd/modules/"
  basename "$module" >>"$root/rmd/modules.order"
done
vcan_install_executable "$root" "$program"
for file in "${extra[@]}"; do
  vcan_install_executable "$root" "$(readlink -f "$file")"
done

{
  for name in RUST_BACKTRACE RUST_TEST_THREADS RUST_LOG NO_COLOR $(compgen -e | grep '^RMD_' || true); do
    [ -n "${!name+x}" ] && printf 'export %s=%q\n' "$name" "${!name}"
  done
  echo 'export RMD_IN_VM=1'
} >"$root/rmd/env"
{
  printf 'set --'
  printf ' %q' "$program" "$@"
  printf '\n'
} >"$root/rmd/command"

(cd "$root" && find . | "$VCAN_CACHE/tools/root/bin/busybox" cpio -o -H newc 2>/dev/null) \
  >"$work/initramfs.cpio"

log="$work/console.log"
status=0
# TCG (software emulation): this machine's KVM is a paravirtual one on which a stock kernel
# boots far slower. No network, no disk; the console is the serial port on stdio.
vcan_qemu_command
timeout -k 10 "$timeout_s" "${VCAN_QEMU[@]}" \
  -accel tcg -cpu max -smp "${RMD_VM_CPUS:-2}" -m "${RMD_VM_MEMORY:-1024M}" -nodefaults -no-user-config -display none \
  -serial stdio -no-reboot -kernel "$VCAN_CACHE/kernel/vmlinux" -initrd "$work/initramfs.cpio" \
  -append 'console=ttyS0 panic=-1 quiet loglevel=3' </dev/null |
  tr -d '\r' | tee "$log" || status=$?

exit_line="$(grep -a -o 'RMD_VM_EXIT=[0-9]*' "$log" | tail -n 1 || true)"
if [ -z "$exit_line" ]; then
  vcan_log "the VM stopped without reporting an exit status (timeout, kernel panic or qemu" \
    "failure; pipeline status $status)"
  exit 125
fi
exit "${exit_line#RMD_VM_EXIT=}"
