# shellcheck shell=bash
# Shared helpers of the SocketCAN kernel-test harness (sourced, not run).
#
# Everything the VM needs comes from Debian's archive through apt, unpacked into a cache folder
# and never installed: a stock bookworm kernel (linux-image-*-amd64: its ELF vmlinux and the
# CAN modules), qemu-system-x86 with the libraries this machine lacks, and busybox-static.
#
# Cache: $RMD_VCAN_CACHE, default <repo>/target/vcan-cache. Delete it to start over.

VCAN_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VCAN_REPO="$(cd "$VCAN_DIR/../.." && pwd)"
VCAN_CACHE="${RMD_VCAN_CACHE:-$VCAN_REPO/target/vcan-cache}"

# The kernel modules loaded in the VM, in dependency order.
VCAN_MODULES=(
  kernel/net/can/can.ko
  kernel/net/can/can-raw.ko
  kernel/drivers/net/can/dev/can-dev.ko
  kernel/drivers/net/can/vcan.ko
  kernel/drivers/net/can/slcan/slcan.ko
)

vcan_log() { echo "vcan: $*" >&2; }
vcan_die() { echo "vcan: error: $*" >&2; exit 2; }

# Runs apt-get; on a machine whose package lists are missing or stale, updates them once and
# retries. Every apt-get of the test scripts holds /tmp/rmd-apt.lock: tests/run-all.sh runs
# them side by side, and apt refuses to run twice at once.
vcan_apt() {
  if ! flock /tmp/rmd-apt.lock apt-get "$@" >"$VCAN_CACHE/apt.log" 2>&1; then
    vcan_log "apt-get $1 failed; updating the package lists and retrying"
    flock /tmp/rmd-apt.lock apt-get update -qq >>"$VCAN_CACHE/apt.log" 2>&1 || true
    flock /tmp/rmd-apt.lock apt-get "$@" >>"$VCAN_CACHE/apt.log" 2>&1 || {
      tail -20 "$VCAN_CACHE/apt.log" >&2
      vcan_die "apt-get $* failed (see $VCAN_CACHE/apt.log)"
    }
  fi
}

# The bookworm kernel image package the linux-image-amd64 metapackage points to.
vcan_kernel_package() {
  local package
  package="$(apt-cache depends linux-image-amd64 2>/dev/null |
    sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*-amd64\)$/\1/p' | head -n 1)"
  if [ -z "$package" ]; then
    flock /tmp/rmd-apt.lock apt-get update -qq >/dev/null 2>&1 || true
    package="$(apt-cache depends linux-image-amd64 2>/dev/null |
      sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*-amd64\)$/\1/p' | head -n 1)"
  fi
  [ -n "$package" ] || vcan_die "cannot resolve linux-image-amd64 with apt-cache"
  echo "$package"
}

# Kernel: vmlinux (ELF, extracted from the bzImage's xz payload) and the CAN modules.
vcan_fetch_kernel() {
  local dir="$VCAN_CACHE/kernel"
  [ -f "$dir/ready" ] && return 0
  local package deb vmlinuz offset
  package="$(vcan_kernel_package)"
  vcan_log "fetching $package"
  rm -rf "$dir" && mkdir -p "$dir/debs" "$dir/root"
  (cd "$dir/debs" && vcan_apt download "$package")
  local debs=("$dir"/debs/*.deb)
  deb="${debs[0]}"
  dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$dir/root" --wildcards './boot/vmlinuz-*' \
    './lib/modules/*/kernel/net/can/*' './lib/modules/*/kernel/drivers/net/can/*'
  local images=("$dir"/root/boot/vmlinuz-*)
  vmlinuz="${images[0]}"
  # The bzImage carries the kernel as an xz stream; booting that ELF directly skips the
  # decompressor (about half the boot time under TCG).
  offset="$(LC_ALL=C grep -obUaP '\xfd7zXZ\x00' "$vmlinuz" | head -n 1 | cut -d: -f1)"
  [ -n "$offset" ] || vcan_die "no xz payload in $vmlinuz"
  tail -c +"$((offset + 1))" "$vmlinuz" | xz -dc 2>/dev/null >"$dir/vmlinux" || true
  head -c 4 "$dir/vmlinux" | grep -q 'ELF' || vcan_die "could not extract vmlinux from $vmlinuz"
  mkdir -p "$dir/modules"
  local module
  for module in "${VCAN_MODULES[@]}"; do
    cp "$dir"/root/lib/modules/*/"$module" "$dir/modules/" ||
      vcan_die "the kernel package has no $module"
  done
  rm -rf "$dir/debs" "$dir/root"
  echo "$package" >"$dir/ready"
}

# qemu-system-x86 (the machine's own if installed, else Debian's unpacked into the cache) and
# a static busybox.
vcan_fetch_tools() {
  local dir="$VCAN_CACHE/tools"
  [ -f "$dir/ready" ] && return 0
  rm -rf "$dir" && mkdir -p "$dir/debs/partial" "$dir/root"
  (cd "$dir/debs" && vcan_apt download busybox-static)
  if ! command -v qemu-system-x86_64 >/dev/null 2>&1; then
    vcan_log "fetching qemu-system-x86 (unpacked into the cache, not installed)"
    # --download-only fetches the package and the dependencies this machine lacks, without
    # touching the installed packages (installing it would replace backported qemu-utils).
    vcan_apt install -y --download-only --no-install-recommends \
      -o Dir::Cache::archives="$dir/debs" qemu-system-x86
  fi
  local deb
  for deb in "$dir"/debs/*.deb; do
    dpkg-deb -x "$deb" "$dir/root"
  done
  [ -x "$dir/root/bin/busybox" ] || vcan_die "busybox-static did not unpack"
  rm -rf "$dir/debs"
  touch "$dir/ready"
}

vcan_fetch() {
  mkdir -p "$VCAN_CACHE"
  vcan_fetch_kernel
  vcan_fetch_tools
}

# shellcheck disable=SC2034 # VCAN_QEMU is this function's result
# Sets VCAN_QEMU to the qemu command (an env(1) call carrying the unpacked libraries and the
# firmware search path when qemu comes from the cache).
vcan_qemu_command() {
  local root="$VCAN_CACHE/tools/root"
  if [ -x "$root/usr/bin/qemu-system-x86_64" ]; then
    VCAN_QEMU=(env "LD_LIBRARY_PATH=$root/usr/lib/x86_64-linux-gnu:$root/lib/x86_64-linux-gnu"
      "$root/usr/bin/qemu-system-x86_64" -L "$root/usr/share/seabios" -L "$root/usr/share/qemu")
  else
    VCAN_QEMU=(qemu-system-x86_64)
  fi
}

# Copies an executable and every library ldd lists into the initramfs root $1, at the same
# absolute paths as on this machine.
vcan_install_executable() {
  local root="$1" file="$2" dest="${3:-$2}" lib
  mkdir -p "$root$(dirname "$dest")"
  cp -L "$file" "$root$dest"
  chmod +x "$root$dest"
  # The VM unpacks its root into RAM: debug builds of the tools are hundreds of MB, mostly
  # debug information (panic messages keep their file:line without it).
  if command -v strip >/dev/null 2>&1; then
    strip --strip-debug "$root$dest" 2>/dev/null || true
  fi
  for lib in $(ldd "$file" 2>/dev/null | grep -o '/[^ ]*' | sort -u); do
    [ -e "$root$lib" ] && continue
    mkdir -p "$root$(dirname "$lib")"
    cp -L "$lib" "$root$lib"
  done
}

# Does this machine have a usable vcan0 and the right to create test interfaces?
vcan_native_ok() {
  ip link show vcan0 2>/dev/null | grep -q ',UP' || return 1
  local probe="rmdprobe$$"
  probe="${probe:0:15}"
  ip link add dev "$probe" type vcan >/dev/null 2>&1 || return 1
  ip link del dev "$probe" >/dev/null 2>&1 || true
  return 0
}
