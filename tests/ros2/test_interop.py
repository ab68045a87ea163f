"""`rmd ros2` (the real-time loop running the joint servo on simulated motors, and the ROS 2
node) against an independent DDS: Eclipse Cyclone DDS.

Run by tests/ros2/run.sh inside a private network namespace (only `lo`, multicast on). The
`rmd` binary comes from $RMD_BIN, the robot is examples/robots/leg4.toml on simulated motors in
real time (--sim), with the servo settings of leg4_servo.toml. Both directions are checked:
Cyclone reads the node's joint_states and diagnostics; Cyclone's joint commands (position,
velocity), trajectories and estop / enable move (or stop) the simulated robot, as seen in
joint_states; bad messages are counted in diagnostics and move nothing; the run ends with the
report and the node's counters. No timing is asserted beyond generous timeouts and a loose
rate band.
"""

import math
import threading
import time

import pytest
from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from rmd_process import (JOINTS, REJECTION_KINDS, TIMEOUT, TOL, Rmd, module_node,
                         wait_until)
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
NODE = f"{NS}/rmd_rt"


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

    def fresh_diag(self):
        """A diagnostics message stamped after this call."""
        now = time.time()

        def newer():
            d = self.diag()
            return d if d is not None and stamp(d.header.stamp) > now else None

        return wait_until("a new diagnostics message", newer)

    def status(self, d, name):
        for s in d.status:
            if s.name == f"{NODE}: {name}":
                return s
        raise AssertionError(f"no '{name}' status in {[s.name for s in d.status]}")

    def counters(self, d=None):
        """The node's input counters from diagnostics (the newest, or `d`)."""
        d = d or self.diag()
        return None if d is None else values(self.status(d, "ros2 inputs"))

    def wait_counter(self, key, above):
        return wait_until(
            f"diagnostics counter {key} > {above}",
            lambda: (c := self.counters()) is not None and int(c[key]) > above and c)

    def wait_position(self, joint, target, tol=TOL):
        i = JOINTS.index(joint)
        return wait_until(
            f"{joint} at {target} rad in joint_states",
            lambda: (s := self.state()) is not None and abs(s.position[i] - target) < tol and s)


def stamp(t):
    return t.sec + t.nanosec * 1e-9


def values(status):
    return {kv.key: kv.value for kv in status.values}


@pytest.fixture(scope="module")
def rmd():
    yield from module_node(NS, DOMAIN)


@pytest.fixture(scope="module")
def peer(rmd):
    p = Ros2Peer()
    p.wait_matched()
    return p


def test_joint_states_names_values_stamps_and_rate(peer):
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
            assert len(arr) == 4 and all(math.isfinite(x) for x in arr)
    stamps = [stamp(s.header.stamp) for s in samples]
    assert stamps == sorted(stamps)
    # Stamped with the replies' reception, on the wall clock.
    assert abs(stamps[-1] - time.time()) < 5.0, (stamps[-1], time.time())
    # Configured for 500 Hz; a loose band (best effort may drop, a busy machine may lag).
    rate = len(samples) / window
    assert 100 < rate < 1000, rate
    # The leg powered up in its pose (hip_aa 0, hip_fe -30, knee 60, ankle -30 degrees) and the
    # servo holds it.
    pose = [0.0, -math.pi / 6, math.pi / 3, -math.pi / 6]
    for got, want in zip(samples[-1].position, pose):
        assert abs(got - want) < 0.05, (samples[-1].position, pose)


def test_diagnostics_report_loop_motors_and_inputs(peer):
    d = peer.fresh_diag()
    loop = values(peer.status(d, "loop"))
    assert loop["enabled"] == "true"
    assert float(loop["period_us"]) == 1000.0
    assert int(loop["cycles"]) > 100
    for key in ("deadline_misses", "missing_replies", "work_p99_us", "wake_latency_p99_us"):
        assert key in loop, (key, loop)
    for i, j in enumerate(JOINTS):
        motor = peer.status(d, f"motor {j}")
        v = values(motor)
        assert 0 < float(v["temperature_c"]) < 100
        # leg4: four motors per bus at 1 kHz leave no room for the health rotation, and the
        # diagnostics say why the voltage is not measured.
        assert "voltage_v" not in v and v["voltage"].startswith("not measured"), v
        assert "health rotation" in v["voltage"], v
        assert v["faults"] == "", v
        assert v["mode"] == "hold", v
        assert int(v["missing_replies"]) >= 0
        assert motor.hardware_id == f"leg (simulated) motor {i + 1} (0x{0x141 + i:x})"
    assert "rejected_total" in peer.counters(d)


def test_joint_commands_move_the_robot(peer):
    # The topic_based_ros2_control convention: every joint, all three arrays filled.
    target = [0.1, -0.4, 1.2, -0.3]
    peer.commands.write(JointState(name=JOINTS, position=target, velocity=[0.0] * 4,
                                   effort=[0.0] * 4))
    for j, x in zip(JOINTS, target):
        peer.wait_position(j, x)
    # The joint_state_topic_hardware_interface convention: only the commanded array.
    peer.commands.write(JointState(name=["knee"], position=[0.8]))
    peer.wait_position("knee", 0.8)
    # The other joints stayed where they were told.
    s = peer.fresh_state()
    assert abs(s.position[0] - 0.1) < TOL and abs(s.position[1] + 0.4) < TOL, s.position
    d = values(peer.status(peer.fresh_diag(), "motor knee"))
    assert int(d["setpoints"]) >= 2, d


def test_velocity_commands_move_the_joint_at_that_speed(peer):
    start = peer.fresh_state().position[3]
    streaming = threading.Event()
    streaming.set()

    def stream():
        # Renewed well within stale_after_ms (500 ms), as a streaming commander does.
        while streaming.is_set():
            peer.commands.write(JointState(name=["ankle"], velocity=[0.5]))
            time.sleep(0.02)

    sender = threading.Thread(target=stream)
    sender.start()
    speeds = []
    try:
        t_end = time.monotonic() + 0.6
        while time.monotonic() < t_end:
            time.sleep(0.03)
            speeds.append(peer.fresh_state().velocity[3])
    finally:
        streaming.clear()
        sender.join()
    moved = peer.fresh_state().position[3] - start
    assert 0.15 < moved < 0.45, moved
    # Past the start the joint turns at the commanded speed (the median of the later half of
    # the samples: one sample of a loaded machine's hiccup does not decide).
    late = sorted(speeds[len(speeds) // 2:])
    assert abs(late[len(late) // 2] - 0.5) < 0.1, speeds
    # No renewal: the setpoint goes stale and the joint holds.
    time.sleep(0.8)
    held = peer.fresh_state().position[3]
    time.sleep(0.3)
    assert abs(peer.fresh_state().position[3] - held) < TOL
    d = values(peer.status(peer.fresh_diag(), "motor ankle"))
    assert int(d["stale_events"]) >= 1, d


def test_effort_commands_reach_the_motor_as_that_torque(peer):
    ankle = JOINTS.index("ankle")
    streaming = threading.Event()
    streaming.set()

    def stream():
        while streaming.is_set():
            peer.commands.write(JointState(name=["ankle"], effort=[0.3]))
            time.sleep(0.02)

    sender = threading.Thread(target=stream)
    sender.start()
    efforts = []
    try:
        t_end = time.monotonic() + 0.4
        while time.monotonic() < t_end:
            time.sleep(0.03)
            efforts.append(peer.fresh_state().effort[ankle])
        mode = values(peer.status(peer.fresh_diag(), "motor ankle"))["mode"]
    finally:
        streaming.clear()
        sender.join()
    # The measured torque (the motor's current times the torque constant) is the command's,
    # within the current's resolution, once the first commands arrived.
    late = sorted(efforts[len(efforts) // 2:])
    assert abs(late[len(late) // 2] - 0.3) < 0.05, efforts
    assert mode == "effort", mode
    # Stale, then held where it went: back to a position for the tests after this one.
    peer.commands.write(JointState(name=["ankle"], position=[-0.3]))
    peer.wait_position("ankle", -0.3)


def test_trajectory_moves_the_robot(peer):
    t = JointTrajectory(joint_names=["hip_fe", "hip_aa"], points=[
        JointTrajectoryPoint(positions=[-0.2, 0.2], time_from_start=Duration(0, 500_000_000)),
        JointTrajectoryPoint(positions=[0.3, -0.1], velocities=[0.0, 0.0],
                             time_from_start=Duration(1, 100_000_000)),
    ])
    sent = time.monotonic()
    peer.trajectory.write(t)
    seen_first = []

    def at_end():
        s = peer.state()
        if s is None:
            return None
        if abs(s.position[1] + 0.2) < 0.05 and abs(s.position[0] - 0.2) < 0.05:
            seen_first.append(s)
        return abs(s.position[1] - 0.3) < TOL and abs(s.position[0] + 0.1) < TOL

    wait_until("hip_fe and hip_aa at the trajectory's last point", at_end, poll=0.002)
    # It passed by the first point on its way, and took about the trajectory's time.
    assert seen_first, "never near the first point"
    assert time.monotonic() - sent > 0.9
    d = values(peer.status(peer.fresh_diag(), "motor hip_fe"))
    assert int(d["trajectories"]) >= 1, d
    loop = values(peer.status(peer.diag(), "loop"))
    assert "every point on time" in loop["last_trajectory"], loop


def test_bad_messages_are_counted_and_move_nothing(peer):
    before = peer.fresh_state()
    c0 = peer.counters(peer.fresh_diag())
    bad_commands = {
        "unknown_joint": JointState(name=["elbow"], position=[0.1]),
        "not_finite": JointState(name=["knee"], position=[float("nan")]),
        "out_of_limit": JointState(name=["knee"], position=[5.0]),
        "length_mismatch": JointState(name=["hip_aa", "knee"], position=[0.1]),
        "empty": JointState(),
        "duplicate_joint": JointState(name=["knee", "knee"], position=[0.1, 0.2]),
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
    bad_trajectories = {
        "bad_time": JointTrajectory(joint_names=["knee"], points=[
            JointTrajectoryPoint(positions=[0.1], time_from_start=Duration(2, 0)),
            JointTrajectoryPoint(positions=[0.2], time_from_start=Duration(1, 0)),
        ]),
        "unsupported": JointTrajectory(joint_names=["knee"], points=[
            JointTrajectoryPoint(positions=[0.1], effort=[1.0],
                                 time_from_start=Duration(1, 0)),
        ]),
        # Valid for the node, refused by the servo's own check: a trajectory must end at rest.
        "infeasible": JointTrajectory(joint_names=["knee"], points=[
            JointTrajectoryPoint(positions=[0.9], velocities=[0.5],
                                 time_from_start=Duration(1, 0)),
        ]),
    }
    for m in bad_trajectories.values():
        peer.trajectory.write(m)
    expected = {k: int(c0[f"rejected_{k}"]) + 1
                for k in [*bad_commands, *bad_trajectories, "malformed"]}
    wait_until("every rejection counted in diagnostics", lambda: (
        (c := peer.counters()) is not None
        and all(int(c[f"rejected_{k}"]) >= n for k, n in expected.items()) and c))
    c1 = peer.counters()
    assert c1["commands_accepted"] == c0["commands_accepted"]
    assert c1["trajectories_accepted"] == c0["trajectories_accepted"]
    assert "last_rejection" in c1
    time.sleep(0.3)
    after = peer.fresh_state()
    for b, a in zip(before.position, after.position):
        assert abs(b - a) < TOL, (before.position, after.position)


def test_oversized_input_is_refused_bounded_and_echoed_only_in_part(peer, rmd):
    """A joint name of 100 kB (refused while decoding, a 32-byte excerpt in diagnostics) and
    one of 10 MB (dropped unread by DDS, over the node's 4 MiB sample limit): the node's memory
    stays put, diagnostics keep coming, nothing moves, and commands work after."""
    before = peer.fresh_state()
    c0 = peer.counters(peer.fresh_diag())
    oversized0 = int(c0.get("rejected_oversized", "0"))
    rss0 = rmd.rss_kib()
    peer.commands.write(JointState(name=["knee" + "x" * 100_000], position=[0.5]))
    c = wait_until("the 100 kB name counted as oversized", lambda: (
        (c := peer.counters()) is not None
        and int(c.get("rejected_oversized", "0")) > oversized0 and c))
    last = c["last_rejection"]
    assert "name of 100004 bytes" in last and 'begins "knee' in last, last
    assert len(last) < 300, len(last)
    peer.commands.write(JointState(name=["a" * 10_000_000], position=[0.5]))
    c = wait_until("the 10 MB name counted as oversized", lambda: (
        (c := peer.counters()) is not None
        and int(c["rejected_oversized"]) > oversized0 + 1 and c))
    assert "dropped unread" in c["last_rejection"], c["last_rejection"]
    # Diagnostics keep coming, none carrying the bad text.
    for _ in range(3):
        d = peer.fresh_diag()
        size = sum(len(kv.value) for s in d.status for kv in s.values)
        size += sum(len(s.message) for s in d.status)
        assert size < 20_000, size
    # The node holds no copy of it (it grew by ~60 MB a second when it echoed it).
    grown_mib = (rmd.rss_kib() - rss0) / 1024
    assert grown_mib < 30, f"rmd ros2 grew by {grown_mib:.0f} MiB"
    after = peer.fresh_state()
    for b, a in zip(before.position, after.position):
        assert abs(b - a) < TOL, (before.position, after.position)
    peer.commands.write(JointState(name=["knee"], position=[1.1]))
    peer.wait_position("knee", 1.1)


def test_estop_stops_the_robot_and_refuses_commands_until_enabled(peer):
    c0 = peer.counters(peer.fresh_diag())
    peer.enable.write(Bool(data=False))
    peer.wait_counter("enables_accepted", int(c0["enables_accepted"]))
    # Disabled: zero torque on every joint, the loop (and joint_states) going on.
    d = wait_until("diagnostics of the estopped robot", lambda: (
        (d := peer.fresh_diag()) is not None
        and values(peer.status(d, "loop"))["enabled"] == "false" and d))
    assert peer.status(d, "loop").message.startswith("estopped")
    for j in JOINTS:
        assert values(peer.status(d, f"motor {j}"))["mode"] == "disabled"
    knee = peer.fresh_state().position[2]
    refused = int(peer.counters()["rejected_port_refused"])
    peer.commands.write(JointState(name=["knee"], position=[1.4]))
    peer.wait_counter("rejected_port_refused", refused)
    time.sleep(0.3)
    assert abs(peer.fresh_state().position[2] - knee) < TOL
    c1 = peer.counters()
    peer.enable.write(Bool(data=True))
    peer.wait_counter("enables_accepted", int(c1["enables_accepted"]))
    peer.commands.write(JointState(name=["knee"], position=[1.4]))
    peer.wait_position("knee", 1.4)


def test_ctrl_c_ends_the_run_with_the_report_and_a_last_word(peer, rmd):
    code, report, err = rmd.interrupt()
    assert code == 130, err
    assert report["stop_reason"] == "stop requested", report
    assert report["normal_stop"] is True
    assert all(m["off_confirmed"] for m in report["safe_stop"]["motors"]), report["safe_stop"]
    ros2 = report["ros2"]
    for kind in REJECTION_KINDS:
        assert ros2["rejected"][kind] >= 1, (kind, ros2)
    assert ros2["commands_accepted"] >= 10 and ros2["trajectories_accepted"] >= 1, ros2
    assert ros2["enables_accepted"] >= 2, ros2
    assert ros2["publish_errors"] == 0, ros2
    assert ros2["joint_states_published"] > 1000, ros2
    # The node's last diagnostics say how the loop ended.
    last = wait_until("the last diagnostics", lambda: (
        (d := peer.diag()) is not None and "stopped" in values(peer.status(d, "loop")) and d),
        timeout=5.0)
    assert values(peer.status(last, "loop"))["stopped"] == "stop requested"


def test_estop_can_end_the_run_when_asked_to():
    r = Rmd("--estop-ends-run", "--seconds", "60", namespace=NS, domain=DOMAIN)
    try:
        p = Ros2Peer()
        p.wait_matched()
        p.fresh_state()
        # Written until the run ends: the module's other node (same namespace) may be the
        # only match when the first write goes out, and a late-joining reader of a volatile
        # topic never sees it.
        deadline = time.monotonic() + TIMEOUT
        while r.proc.poll() is None and time.monotonic() < deadline:
            p.enable.write(Bool(data=False))
            time.sleep(0.2)
        code, report, err = r.wait()
    finally:
        r.kill()
    assert code == 1, err
    assert report["stop_reason"] == "HALTED by the controller: estop", report
    assert report["normal_stop"] is False
    assert all(m["off_confirmed"] for m in report["safe_stop"]["motors"]), report["safe_stop"]
