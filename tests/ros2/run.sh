#!/usr/bin/env bash
# Interoperability test of the rmd-rt ROS 2 node against an independent DDS: Eclipse Cyclone DDS
# (its Python binding, which bundles the C library), in a private network namespace where `lo`
# is the only interface, multicast enabled on it. Touches no real network.
#
# Creates (once) a venv under target/ with the pinned tests/ros2/requirements.txt, builds the
# node on its test-double robot (examples/fake_node.rs of crates/rmd-ros2), and runs
# tests/ros2/test_interop.py with pytest inside the namespace. Fails on any failed check.
# Usage: ./tests/ros2/run.sh [pytest args...]
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)

venv="$root/target/ros2-venv"
req="$root/tests/ros2/requirements.txt"
stamp="$venv/.requirements"
if [[ ! -x "$venv/bin/python" ]] || ! cmp -s "$req" "$stamp"; then
  echo "ros2 interop: installing $(grep -v '^#' "$req" | tr '\n' ' ')into $venv"
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$req"
  cp "$req" "$stamp"
fi

cargo build --quiet -p rmd-ros2 --example fake_node
node="${CARGO_TARGET_DIR:-$root/target}/debug/examples/fake_node"

# A network namespace of our own: as root a plain one, otherwise inside a user namespace.
if [[ $(id -u) -eq 0 ]]; then unshare=(unshare --net); else unshare=(unshare --map-root-user --net); fi

# Cyclone DDS on lo only, multicast on (SPDP discovery by multicast, as on a real network).
cyclone_xml='<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces><AllowMulticast>true</AllowMulticast></General></Domain></CycloneDDS>'

exec "${unshare[@]}" env RMD_ROS2_NODE="$node" CYCLONEDDS_URI="$cyclone_xml" \
  PYTHONDONTWRITEBYTECODE=1 bash -c '
  set -euo pipefail
  ip link set lo up
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo
  cd tests/ros2
  exec "$0" -m pytest -p no:cacheprovider -v "$@" test_interop.py
' "$venv/bin/python" "$@"
