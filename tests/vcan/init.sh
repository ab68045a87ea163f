#!/bin/busybox sh
# /init of the kernel-test VM: load the CAN modules, create vcan0, run the program, report its
# exit status on the console as RMD_VM_EXIT=<status>, power off.
/bin/busybox --install -s /bin
export PATH=/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mkdir -p /dev/pts /tmp
mount -t devpts devpts /dev/pts
# No tmpfs on /tmp: the root is already in RAM, and the test binaries are installed at their
# host paths, which may lie under /tmp (a CI clone in /tmp would be hidden by a mount).

finish() {
  printf '\nRMD_VM_EXIT=%s\n' "$1"
  sync
  poweroff -f
}

while read -r module; do
  insmod "/rmd/modules/$module" || { echo "vm: insmod $module failed"; finish 126; }
done </rmd/modules.order
ip link set lo up
{ ip link add dev vcan0 type vcan && ip link set vcan0 up; } ||
  { echo "vm: cannot create vcan0"; finish 126; }

# Environment and command line of the program, written by run-in-vm.sh.
# shellcheck disable=SC1091
. /rmd/env
# shellcheck disable=SC1091
. /rmd/command
cd /tmp || finish 126
"$@"
finish "$?"
