"""`rmd ros2` against an independent DDS: eProsima Fast DDS 2.9.1 (Debian's libfastrtps-dev),
the middleware of ROS 2's default rmw (rmw_fastrtps_cpp), through the C++ peer of
fastdds_peer.cpp ($FASTDDS_PEER), driven line by line.

Run by tests/ros2/run.sh inside its private network namespace (only `lo`, multicast on). Checks:
Fast DDS reads the node's joint_states; its position commands in both bridge conventions move
the simulated joints; estop and enable; its reliable commands are acknowledged by the node
itself (the peer's writers announce their samples only every 30 s, so an acknowledgement that
waited for a HEARTBEAT would take 30 s); it sees the node leave when the node announces it (a
disposal it understands, not the end of a lease); its preemptive ACKNACKs are answered. The
figures (acknowledgement and departure times) are printed: `tests/ros2/run.sh -k fastdds -s`.
No timing is asserted beyond bounds that only the old behaviour could exceed (an
acknowledgement at the 30 s heartbeat; removal at the end of the node's lease, or never).
"""

import math
import os
import socket
import statistics
import struct
import subprocess
import threading
import time

import pytest

from rmd_process import JOINTS, TOL, Rmd, module_node, wait_until

DOMAIN = 8
NS = "/rmd_fast"
# The peer's writers announce their samples (HEARTBEAT) this rarely: an acknowledgement
# within a few seconds is the node's own.
HEARTBEAT_MS = 30_000
# rclcpp's default history depth: Fast DDS attaches no HEARTBEAT to a sample while its history
# is not full.
DEPTH = 10


class FastDdsPeer:
    """The C++ Fast DDS peer as a process: one request line, one answer line; event lines
    (`participant ...`) are collected as they come."""

    def __init__(self):
        self.proc = subprocess.Popen(
            [os.environ["FASTDDS_PEER"], str(DOMAIN), NS, str(HEARTBEAT_MS), str(DEPTH)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.events = []
        self.answers = []
        self.cond = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            with self.cond:
                if line.startswith("participant "):
                    what, t = line.split()[1:3]
                    self.events.append((what, float(t)))
                else:
                    self.answers.append(line.strip())
                self.cond.notify_all()

    def ask(self, request, timeout=60.0):
        with self.cond:
            self.answers.clear()
            self.proc.stdin.write(request + "\n")
            self.proc.stdin.flush()
            if not self.cond.wait_for(lambda: self.answers, timeout=timeout):
                raise AssertionError(f"the Fast DDS peer did not answer {request!r}")
            return self.answers.pop(0)

    def matched(self):
        return [int(x) for x in self.ask("matched").split()[1:]]

    def state(self):
        """The newest joint_states sample: (names, positions, velocities, efforts), or None."""
        words = self.ask("state").split()
        if words[1] == "none":
            return None
        n = int(words[4])
        names = words[5:5 + n]
        values = [float(x) for x in words[5 + n:]]
        assert len(values) == 3 * n, words
        return names, values[:n], values[n:2 * n], values[2 * n:]

    def command(self, names, position=(), velocity=(), effort=()):
        parts = ["cmd", str(len(names)), *names]
        for arr in (position, velocity, effort):
            parts += [str(len(arr)), *(repr(float(x)) for x in arr)]
        assert self.ask(" ".join(parts)) == "ok"

    def enable(self, on):
        assert self.ask(f"enable {1 if on else 0}") == "ok"

    def ack(self, timeout_ms):
        """Waits for the last sample's acknowledgement: (acknowledged, seconds since written)."""
        _, result, us = self.ask(f"ack {timeout_ms}", timeout=timeout_ms / 1000 + 30).split()
        return result == "ok", int(us) / 1e6

    def wait_position(self, joint, target, tol=TOL):
        i = JOINTS.index(joint)
        return wait_until(f"{joint} at {target} rad in Fast DDS's joint_states", lambda: (
            (s := self.state()) is not None and abs(s[1][i] - target) < tol and s))

    def close(self):
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write("quit\n")
                self.proc.stdin.flush()
                self.proc.wait(timeout=10)
            except (BrokenPipeError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()


@pytest.fixture(scope="module")
def rmd():
    yield from module_node(NS, DOMAIN)


@pytest.fixture(scope="module")
def fast(rmd):
    p = FastDdsPeer()
    wait_until("Fast DDS matching the node's readers and writer", lambda: p.matched() == [1, 1, 1])
    yield p
    p.close()


def test_fast_dds_reads_the_joint_states(fast):
    s = wait_until("a joint_states sample in Fast DDS", fast.state)
    names, position, velocity, effort = s
    assert names == JOINTS
    for arr in (position, velocity, effort):
        assert len(arr) == 4 and all(math.isfinite(x) for x in arr), s
    # The leg's power-up pose, held by the servo.
    pose = [0.0, -math.pi / 6, math.pi / 3, -math.pi / 6]
    for got, want in zip(position, pose):
        assert abs(got - want) < 0.05, (position, pose)
    # Samples keep coming (best effort, 500 Hz configured; the reader keeps the last 5).
    time.sleep(0.2)
    assert int(fast.ask("state").split()[1]) >= 3


def test_fast_dds_position_commands_in_both_bridge_conventions(fast):
    # topic_based_ros2_control: every joint, all three arrays filled.
    target = [0.1, -0.4, 1.2, -0.3]
    fast.command(JOINTS, position=target, velocity=[0.0] * 4, effort=[0.0] * 4)
    for j, x in zip(JOINTS, target):
        fast.wait_position(j, x)
    # joint_state_topic_hardware_interface: only the commanded array.
    fast.command(["knee"], position=[0.8])
    fast.wait_position("knee", 0.8)
    s = fast.state()
    assert abs(s[1][0] - 0.1) < TOL and abs(s[1][1] + 0.4) < TOL, s


def test_fast_dds_estop_and_enable(fast):
    knee = fast.wait_position("knee", 0.8)[1][2]
    fast.enable(False)
    assert fast.ack(10_000)[0]
    # The node takes each topic in turn: give it the moment to act on what it acknowledged.
    time.sleep(0.3)
    # Disabled: a command is refused and nothing moves. (A position setpoint is a step, taken as
    # hard as the gains allow: 0.3 rad stays well below the knee's velocity limit even when a
    # loaded host runs the loop late; 0.5 rad reached 573 deg/s there, past 360 + 180 deg/s.)
    fast.command(["knee"], position=[1.1])
    time.sleep(0.5)
    assert abs(fast.state()[1][2] - knee) < 0.05
    fast.enable(True)
    assert fast.ack(10_000)[0]
    time.sleep(0.3)
    fast.command(["knee"], position=[1.1])
    fast.wait_position("knee", 1.1)


def test_fast_dds_reliable_commands_are_acknowledged_by_the_node(fast):
    """Each command acknowledged long before the writer's 30 s HEARTBEAT; spaced commands at
    once, back-to-back ones within the node's 100 ms acknowledgement period."""
    spaced, burst = [], []
    for i in range(10):
        time.sleep(0.15)
        fast.command(["hip_aa"], position=[0.01 * i])
        ok, t = fast.ack(5_000)
        assert ok, f"command {i} not acknowledged within 5 s"
        spaced.append(t)
    for i in range(10):
        fast.command(["hip_aa"], position=[0.01 * i])
        ok, t = fast.ack(5_000)
        assert ok, f"command {i} of the burst not acknowledged within 5 s"
        burst.append(t)
    ms = lambda xs: f"p50 {statistics.median(xs) * 1e3:.1f} ms, max {max(xs) * 1e3:.1f} ms"
    print(f"\nFIGURE fastdds ack, commands 150 ms apart: {ms(spaced)}")
    print(f"FIGURE fastdds ack, commands back to back: {ms(burst)}")


def count_liveliness_acknacks(seconds):
    """ACKNACKs from Fast DDS (vendor 1.15) to the participant-message (liveliness) writer
    (entity 0x000200c2) seen on `lo` in `seconds`: a raw packet socket parsing RTPS."""
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(0x0003))
    s.bind(("lo", 0))
    s.settimeout(0.2)
    count = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            frame = s.recv(65536)
        except socket.timeout:
            continue
        if len(frame) < 14 + 20 + 8 + 20 or frame[12:14] != b"\x08\x00" or frame[23] != 17:
            continue
        ihl = (frame[14] & 0x0F) * 4
        rtps = frame[14 + ihl + 8:]
        if rtps[:4] != b"RTPS" or rtps[6:8] != b"\x01\x0f":
            continue
        pos = 20
        while pos + 4 <= len(rtps):
            kind, flags = rtps[pos], rtps[pos + 1]
            length = struct.unpack("<H" if flags & 1 else ">H", rtps[pos + 2:pos + 4])[0]
            body = rtps[pos + 4:pos + 4 + length]
            if kind == 0x06 and body[4:8] == b"\x00\x02\x00\xc2":
                count += 1
            if length == 0:
                break
            pos += 4 + length
    s.close()
    return count


def test_fast_dds_preemptive_acknacks_are_answered(fast):
    # Fast DDS repeats an unanswered preemptive ACKNACK to a writer every ~70 ms (about 40
    # in 3 s); answered, it sends at most the odd one.
    n = count_liveliness_acknacks(3.0)
    print(f"\nFIGURE fastdds ACKNACKs to the liveliness writer in 3 s: {n}")
    assert n <= 5, n


def test_fast_dds_sees_the_node_leave(fast, rmd):
    """The node leaves three times (this module's, then two more, one at a time: two real-time
    loops at once are more than a loaded 2-core machine keeps up with); each time Fast DDS
    removes it on its disposal ('removed', not 'dropped' at the end of its lease) and unmatches
    its endpoints."""
    from_signal, from_exit = [], []
    node = rmd
    for run in range(3):
        if run > 0:
            node = Rmd(namespace=NS, domain=DOMAIN)
        try:
            wait_until("Fast DDS matching the node", lambda: fast.matched() == [1, 1, 1])
            seen = len(fast.events)
            t_signal = time.monotonic()
            code, _, err = node.interrupt()
            t_exit = time.monotonic()
            assert code == 130, err
            gone = wait_until("Fast DDS removing the node", lambda: (
                [e for e in fast.events[seen:] if e[0] in ("removed", "dropped")]), timeout=15)
            assert gone[0][0] == "removed", gone
            wait_until("the node's endpoints unmatched", lambda: fast.matched() == [0, 0, 0],
                       timeout=15)
            from_signal.append(gone[0][1] - t_signal)
            from_exit.append(gone[0][1] - t_exit)
        finally:
            node.kill()
    print(f"\nFIGURE fastdds departure after SIGINT: {[round(x, 3) for x in from_signal]} s; "
          f"after the process exited: {[round(x, 3) for x in from_exit]} s")
