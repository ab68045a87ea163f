#!/usr/bin/env bash
# Interoperability tests of `rmd ros2` (the real-time loop running the joint servo on simulated
# motors, and the ROS 2 node) against two independent DDS implementations, in a private network
# namespace where `lo` is the only interface, multicast enabled on it. Touches no real network.
#
# - Eclipse Cyclone DDS (its Python binding, which bundles the C library; test_interop.py), from
#   a venv under target/ with the pinned tests/ros2/requirements.txt, created once;
# - eProsima Fast DDS 2.9.1, Debian's libfastrtps-dev (test_fastdds.py, through the C++ peer
#   fastdds_peer.cpp, compiled here into target/fastdds/). Installed with apt-get when missing
#   and this runs as root; otherwise it fails saying what to install.
# - `--network` (test_network.py): a second namespace on a veth pair, made by the test.
#
# Builds `rmd` and runs the three with pytest inside the namespace, where they drive
# `rmd ros2 --robot examples/robots/leg4.toml --sim` in real time. Fails on any failed check,
# and clearly when no network namespace can be made.
# Usage: ./tests/ros2/run.sh [pytest args...]
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=tests/workspace-build.sh
source tests/workspace-build.sh
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

cargo build --quiet "${RMD_WORKSPACE[@]}" --bins --examples
target="${CARGO_TARGET_DIR:-$root/target}"
rmd="$target/debug/rmd"

# Fast DDS from Debian (bookworm: 2.9.1), and the peer built against it.
fastdds_pkgs=(libfastrtps-dev g++)
if [[ ! -e /usr/include/fastdds/dds/domain/DomainParticipant.hpp ]] || ! command -v g++ >/dev/null; then
  if [[ $(id -u) -eq 0 ]]; then
    echo "ros2 interop: installing ${fastdds_pkgs[*]} (Debian) for the Fast DDS peer"
    flock /tmp/rmd-apt.lock apt-get update -qq
    DEBIAN_FRONTEND=noninteractive flock /tmp/rmd-apt.lock apt-get install -y -qq "${fastdds_pkgs[@]}" >/dev/null
  else
    echo "ros2 interop: the Fast DDS peer needs Debian's ${fastdds_pkgs[*]}: apt-get install ${fastdds_pkgs[*]}" >&2
    exit 1
  fi
fi
peer_src="$root/tests/ros2/fastdds_peer.cpp"
peer="$target/fastdds/fastdds_peer"
if [[ ! -x "$peer" || "$peer_src" -nt "$peer" ]]; then
  mkdir -p "$target/fastdds"
  g++ -std=c++17 -O1 -Wall -Wextra -Werror -o "$peer" "$peer_src" -lfastrtps -lfastcdr
fi

command -v ip >/dev/null || { echo "ros2 interop: needs iproute2's ip (apt-get install iproute2)" >&2; exit 1; }
# A network namespace of our own: as root a plain one, otherwise inside a user namespace.
if [[ $(id -u) -eq 0 ]]; then unshare=(unshare --net); else unshare=(unshare --map-root-user --net); fi
if ! "${unshare[@]}" true 2>/dev/null; then
  echo "ros2 interop: cannot create a private network namespace (${unshare[*]} failed):" >&2
  echo "  this test needs root, or unprivileged user namespaces (kernel.unprivileged_userns_clone=1)," >&2
  echo "  so that DDS traffic stays off every real network" >&2
  exit 1
fi

# Cyclone DDS on lo only, multicast on (SPDP discovery by multicast, as on a real network).
cyclone_xml='<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces><AllowMulticast>true</AllowMulticast></General></Domain></CycloneDDS>'

exec "${unshare[@]}" env RMD_BIN="$rmd" FASTDDS_PEER="$peer" CYCLONEDDS_URI="$cyclone_xml" \
  PYTHONDONTWRITEBYTECODE=1 bash -c '
  set -euo pipefail
  ip link set lo up
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo
  cd tests/ros2
  exec "$0" -m pytest -p no:cacheprovider -v "$@" test_interop.py test_fastdds.py test_network.py
' "$venv/bin/python" "$@"
