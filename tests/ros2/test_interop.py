"""The rmd-rt ROS 2 node (on its fake robot) against an independent DDS: Eclipse Cyclone DDS.

Run by tests/ros2/run.sh inside a private network namespace (only `lo`, multicast on). The
node's binary comes from $RMD_ROS2_NODE. Both directions are checked: Cyclone reads the
node's joint_states and diagnostics; Cyclone's joint commands, trajectories and estop move (or
stop) the robot, as seen in joint_states; bad messages are counted in diagnostics and move
nothing. No timing is asserted beyond generous timeouts and a loose rate band.
"""

import math
import os
import signal
import subprocess
import threading
import time

import pytest
from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_types import (
    NotAJointState,
    Bool,
    DiagnosticArray,
    Duration,
    JointState,
    JointTrajectory,
    JointTrajectoryPoint,
)

DOMAIN = 7
NS = "/rmd_test"
JOINTS = ["hip", "knee", "wrist"]
TIMEOUT = 30.0


def wait_until(what, predicate, timeout=TIMEOUT, poll=0.02):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


class Node:
    """The node's process: started with the test-double robot, stopped with SIGINT."""

    def __init__(self):
        binary = os.environ["RMD_ROS2_NODE"]
        self.proc = subprocess.Popen(
            [binary, "--namespace", NS, "--domain-id", str(DOMAIN), "--network", "127.0.0.1",
             "--rate-hz", "500"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.lines = []
        self.ready = threading.Event()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        if not self.ready.wait(TIMEOUT):
            self.proc.kill()
            raise AssertionError(f"node did not start: {self.proc.stderr.read()}")

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line.strip())
            if line.startswith("READY"):
                self.ready.set()

    def stop(self):
        self.proc.send_signal(signal.SIGINT)
        code = self.proc.wait(TIMEOUT)
        self.reader.join(TIMEOUT)
        stderr = self.proc.stderr.read()
        assert code == 0, f"node exited with {code}: {stderr}"
        return {l.split()[1]: int(l.split()[2]) for l in self.lines if l.startswith("stat ")}


class Ros2Peer:
    """A ROS 2 peer written against Cyclone DDS only: the topics with rt/ prefixes and ROS 2
    QoS as stock ROS 2 tools and ros2_control's topic bridges use them."""

    def __init__(self):
        self.dp = DomainParticipant(DOMAIN)
        sensor = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(50),
                     Policy.Durability.Volatile)
        reliable_in = Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                          Policy.History.KeepLast(10), Policy.Durability.Volatile)
        # rclcpp::QoS(1), as topic_based_ros2_control publishes joint commands.
        reliable_out = Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                           Policy.History.KeepLast(1), Policy.Durability.Volatile)
        t = lambda name, typ: Topic(self.dp, name, typ)
        self.states = DataReader(self.dp, t(f"rt{NS}/joint_states", JointState), qos=sensor)
        self.diagnostics = DataReader(self.dp, t("rt/diagnostics", DiagnosticArray),
                                      qos=reliable_in)
        self.commands = DataWriter(self.dp, t(f"rt{NS}/joint_commands", JointState),
                                   qos=reliable_out)
        self.trajectory = DataWriter(self.dp, t(f"rt{NS}/joint_trajectory", JointTrajectory),
                                     qos=reliable_out)
        self.enable = DataWriter(self.dp, t(f"rt{NS}/enable", Bool), qos=reliable_out)
        self.last_state = None
        self.last_diag = None

    def wait_matched(self):
        for w in (self.commands, self.trajectory, self.enable):
            wait_until(f"the node's reader of {w.topic.name}",
                       lambda w=w: len(w.get_matched_subscriptions()) > 0)
        for r in (self.states, self.diagnostics):
            wait_until(f"the node's writer of {r.topic.name}",
                       lambda r=r: len(r.get_matched_publications()) > 0)

    def state(self):
        """The newest joint_states sample (or the last one seen)."""
        for s in self.states.take(N=100):
            self.last_state = s
        return self.last_state

    def fresh_state(self):
        self.state()
        self.last_state = None
        return wait_until("a joint_states sample", self.state)

    def diag(self):
        for d in self.diagnostics.take(N=10):
            self.last_diag = d
        return self.last_diag

    def counters(self):
        """The node's counters from its newest diagnostics."""
        d = self.diag()
        if d is None:
            return None
        for s in d.status:
            if s.name == f"{NS}/rmd_rt: ros2 inputs":
                return {kv.key: kv.value for kv in s.values}
        raise AssertionError(f"no 'ros2 inputs' status in {[s.name for s in d.status]}")

    def fresh_counters(self):
        """The counters from a diagnostics message stamped after this call."""
        now = time.time()

        def newer():
            d = self.diag()
            return d is not None and d.header.stamp.sec + d.header.stamp.nanosec * 1e-9 > now

        wait_until("a new diagnostics message", newer)
        return self.counters()

    def wait_counter(self, key, above):
        return wait_until(
            f"diagnostics counter {key} > {above}",
            lambda: (c := self.counters()) is not None and int(c[key]) > above and c)

    def wait_position(self, joint, target, tol=2e-3):
        i = JOINTS.index(joint)
        return wait_until(
            f"{joint} at {target} rad in joint_states",
            lambda: (s := self.state()) is not None and abs(s.position[i] - target) < tol and s)


@pytest.fixture(scope="module")
def node():
    n = Node()
    yield n
    stats = n.stop()
    # Every rejection the tests provoked is in the final counters too.
    for kind in ["unknown_joint", "not_finite", "out_of_limit", "length_mismatch", "empty",
                 "duplicate_joint", "bad_time", "malformed", "port_refused"]:
        assert stats[f"rejected_{kind}"] >= 1, f"{kind}: {stats}"
    assert stats["commands_accepted"] >= 2 and stats["trajectories_accepted"] >= 1, stats
    assert stats["enables_accepted"] >= 2, stats
    assert stats["publish_errors"] == 0, stats


@pytest.fixture(scope="module")
def peer(node):
    p = Ros2Peer()
    p.wait_matched()
    return p


def test_joint_states_names_values_and_rate(peer):
    peer.fresh_state()
    samples = []
    window = 2.0
    t_end = time.monotonic() + window
    while time.monotonic() < t_end:
        samples.extend(peer.states.take(N=100))
        time.sleep(0.01)
    assert len(samples) > 10
    for s in samples:
        assert list(s.name) == JOINTS
        for arr in (s.position, s.velocity, s.effort):
            assert len(arr) == 3 and all(math.isfinite(x) for x in arr)
        assert s.header.stamp.sec > 1_600_000_000
    stamps = [s.header.stamp.sec + s.header.stamp.nanosec * 1e-9 for s in samples]
    assert stamps == sorted(stamps)
    # Configured for 500 Hz; a loose band (best effort may drop, a busy machine may lag).
    rate = len(samples) / window
    assert 100 < rate < 1000, rate


def test_diagnostics_report_loop_motors_and_inputs(peer):
    d = wait_until("diagnostics", peer.diag)
    by_name = {s.name: s for s in d.status}
    loop = by_name[f"{NS}/rmd_rt: loop"]
    keys = {kv.key for kv in loop.values}
    assert {"period_us", "cycles", "deadline_misses", "missing_replies", "enabled"} <= keys
    for j in JOINTS:
        motor = by_name[f"{NS}/rmd_rt: motor {j}"]
        values = {kv.key: kv.value for kv in motor.values}
        assert float(values["voltage_v"]) == 24.0
        assert 0 < float(values["temperature_c"]) < 100
        assert values["faults"] == ""
        assert motor.level == 0
    assert "rejected_total" in peer.counters()


def test_joint_command_moves_the_robot(peer):
    # The topic_based_ros2_control convention: every joint, all three arrays filled.
    c = JointState(name=JOINTS, position=[0.3, 0.7, -1.0], velocity=[0.0] * 3,
                   effort=[0.0] * 3)
    peer.commands.write(c)
    peer.wait_position("knee", 0.7)
    peer.wait_position("hip", 0.3)
    peer.wait_position("wrist", -1.0)
    # The joint_state_topic_hardware_interface convention: only the commanded array.
    peer.commands.write(JointState(name=["knee"], position=[-0.4]))
    peer.wait_position("knee", -0.4)


def test_trajectory_moves_the_robot(peer):
    t = JointTrajectory(joint_names=["wrist", "hip"], points=[
        JointTrajectoryPoint(positions=[0.0, -0.2], time_from_start=Duration(0, 200_000_000)),
        JointTrajectoryPoint(positions=[0.5, -0.6], velocities=[0.0, 0.0],
                             time_from_start=Duration(0, 500_000_000)),
    ])
    peer.trajectory.write(t)
    peer.wait_position("hip", -0.6)
    peer.wait_position("wrist", 0.5)


def test_bad_messages_are_counted_and_move_nothing(peer):
    before = peer.fresh_state()
    c0 = peer.fresh_counters()
    bad_commands = {
        "unknown_joint": JointState(name=["elbow"], position=[0.1]),
        "not_finite": JointState(name=["knee"], position=[float("nan")]),
        "out_of_limit": JointState(name=["hip"], position=[5.0]),
        "length_mismatch": JointState(name=["hip", "knee"], position=[0.1]),
        "empty": JointState(),
        "duplicate_joint": JointState(name=["hip", "hip"], position=[0.1, 0.2]),
    }
    for m in bad_commands.values():
        peer.commands.write(m)
    # A sample that does not decode as a JointState: another type under JointState's name,
    # from a participant of its own.
    garbage_dp = DomainParticipant(DOMAIN)
    garbage = DataWriter(garbage_dp, Topic(garbage_dp, f"rt{NS}/joint_commands", NotAJointState),
                         qos=Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                                 Policy.History.KeepLast(1)))
    wait_until("the garbage writer to match", lambda: len(garbage.get_matched_subscriptions()) > 0)
    garbage.write(NotAJointState(code=7))
    backwards = JointTrajectory(joint_names=["hip"], points=[
        JointTrajectoryPoint(positions=[0.1], time_from_start=Duration(2, 0)),
        JointTrajectoryPoint(positions=[0.2], time_from_start=Duration(1, 0)),
    ])
    peer.trajectory.write(backwards)
    expected = {k: int(c0[f"rejected_{k}"]) + 1 for k in bad_commands}
    expected["bad_time"] = int(c0["rejected_bad_time"]) + 1
    expected["malformed"] = int(c0["rejected_malformed"]) + 1
    wait_until("every rejection counted in diagnostics", lambda: (
        (c := peer.counters()) is not None
        and all(int(c[f"rejected_{k}"]) >= n for k, n in expected.items()) and c))
    c1 = peer.counters()
    assert c1["commands_accepted"] == c0["commands_accepted"]
    assert c1["trajectories_accepted"] == c0["trajectories_accepted"]
    assert "last_rejection" in c1
    after = peer.fresh_state()
    for b, a in zip(before.position, after.position):
        assert abs(b - a) < 0.01, (before.position, after.position)


def test_estop_stops_commands_until_enabled(peer):
    peer.enable.write(Bool(data=False))
    c0 = peer.wait_counter("enables_accepted", 0)
    refused = int(c0["rejected_port_refused"])
    knee = peer.fresh_state().position[1]
    peer.commands.write(JointState(name=["knee"], position=[1.2]))
    peer.wait_counter("rejected_port_refused", refused)
    assert abs(peer.fresh_state().position[1] - knee) < 0.01
    peer.enable.write(Bool(data=True))
    peer.wait_counter("enables_accepted", int(c0["enables_accepted"]))
    peer.commands.write(JointState(name=["knee"], position=[1.2]))
    peer.wait_position("knee", 1.2)
