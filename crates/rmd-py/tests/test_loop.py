"""The loop from Python: leg4 on simulated motors with the joint servo in Rust, driven by joint
name; where the joints ended, checked against the simulator's ground truth; estop, refusals,
statistics; the MCAP and Foxglove sinks switched on from Python, read back by independent
implementations (the `mcap` reader, a `websockets` client)."""

from __future__ import annotations

import asyncio
import json
import math

import numpy as np
import pytest

import rmd_rt
from conftest import STIFF_SERVO

# A wave of the leg through two poses and back to a third, rad (inside every joint's range).
JOINTS = ["hip_aa", "hip_fe", "knee", "ankle"]
TIMES = [0.6, 1.2, 2.0]
POINTS = [
    [0.15, -0.20, 0.80, -0.30],
    [-0.10, -0.70, 1.40, -0.70],
    [0.05, -0.40, 1.10, -0.45],
]


def sim_joint_rad(loop: rmd_rt.RobotLoop) -> dict:
    """Each joint's true angle in the simulator (leg4's joints turn with their motors)."""
    sim = loop.simulator()
    assert sim is not None
    return {m["joint"]: math.radians(m["output_angle_deg"]) for m in sim.motors()}


def recorded_joint_states(path) -> list:
    """The /joint_states messages of an MCAP file, decoded by the `mcap` reader with its ROS 2
    decoder (an independent CDR implementation): (loop time s, {joint: position rad})."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [
            (
                m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                dict(zip(m.name, m.position)),
            )
            for _, _, _, m in reader.iter_decoded_messages(topics=["/joint_states"])
        ]


def test_four_simulated_motors_follow_a_trajectory_and_end_where_sent(leg4, tmp_path):
    robot = rmd_rt.Robot.from_toml(leg4)
    assert robot.joint_names == JOINTS
    # Virtual time: the loop runs as fast as the CPU allows, so the path is read back from the
    # loop's own recording rather than sampled from this thread. In real time a busy machine
    # (a build beside the tests) can keep the OS from running the loop thread for longer than
    # the stall bound, and the loop then rightly ends with a fault and its motors safe; what
    # this test checks (the path, the end, the stop) needs no real-time scheduling.
    path = tmp_path / "trajectory.mcap"
    with robot.start(sim=True, virtual_time=True, servo_toml=STIFF_SERVO) as loop:
        assert loop.placement == "simulated motors, virtual time"
        start = loop.positions()
        # Powered up in the middle of each joint's window: leg4's folded pose.
        np.testing.assert_allclose(start, np.radians([0.0, -30.0, 60.0, -30.0]), atol=0.01)
        loop.record_mcap(path)
        receipt = loop.send_trajectory(JOINTS, TIMES, np.array(POINTS))
        assert receipt["duration_s"] == pytest.approx(2.0) and receipt["max_lateness_s"] == 0.0
        loop.sleep(TIMES[-1] + 0.4)
        state = loop.state()
        assert state is not None and state["enabled"]
        for name, target in zip(JOINTS, POINTS[-1]):
            joint = state["joints"][name]
            assert joint["mode"] == "hold", (name, joint["mode"])
            assert joint["counters"]["trajectories"] == 1
            assert joint["position_rad"] == pytest.approx(target, abs=0.01), name
        truth = sim_joint_rad(loop)
        for name, target in zip(JOINTS, POINTS[-1]):
            assert truth[name] == pytest.approx(target, abs=0.01), (name, truth[name])
        stats = loop.stats()
        # 2.4 s at 1 kHz of loop time (virtual time skips no tick).
        assert stats is not None and stats["ticks"] >= 2400, stats
        counts = loop.stop_mcap()
        report = loop.stop()
    assert report["normal_stop"] and report["stop_reason"] == "stop requested"
    assert all(m["off_confirmed"] for m in report["safe_stop"]["motors"])
    assert loop.simulator().all_safe()
    assert not loop.is_running()
    # The path on the way, as the loop recorded it: the knee rises past 1.3 rad towards the
    # second point (1.4 rad at 1.2 s) before it comes down to the last (1.1 rad). A busy
    # machine may make the recording drop ticks (counted), never hold the loop back.
    recorded = recorded_joint_states(path)
    assert len(recorded) == counts["written"] and counts["errors"] == 0, counts
    highest_knee = max(p["knee"] for _, p in recorded)
    assert 1.3 < highest_knee < 1.5, highest_knee


def test_setpoints_by_name_and_refusals(leg4):
    robot = rmd_rt.Robot.from_toml(leg4)
    loop = robot.start(
        sim=True,
        virtual_time=True,
        servo_toml=STIFF_SERVO + "\n[joint.knee]\nposition_min_rad = 0.2\nposition_max_rad = 2.0\n",
    )
    try:
        loop.set_positions({"knee": 1.3, "ankle": -0.2})
        loop.set_position("hip_aa", 0.1)
        loop.sleep(0.8)
        positions = dict(zip(loop.joint_names, loop.positions()))
        assert positions["knee"] == pytest.approx(1.3, abs=0.02)
        assert positions["ankle"] == pytest.approx(-0.2, abs=0.02)
        assert positions["hip_aa"] == pytest.approx(0.1, abs=0.02)
        with pytest.raises(rmd_rt.SetpointError, match="toe"):
            loop.set_position("toe", 0.0)
        with pytest.raises(rmd_rt.LimitError, match="knee"):
            loop.set_position("knee", 3.0)  # beyond position_max_rad
        with pytest.raises(rmd_rt.ServoError):
            loop.send_trajectory(["knee"], [0.5, 0.4], [[1.0], [1.1]])  # times not increasing
        with pytest.raises(rmd_rt.ServoError, match="one row per point"):
            loop.send_trajectory(["knee"], [0.5], [[1.0], [1.1]])
        assert loop.state()["joints"]["knee"]["counters"]["rejected"] >= 1
        loop.disable()
        loop.sleep(0.05)
        assert all(j["mode"] == "disabled" for j in loop.state()["joints"].values())
        with pytest.raises(rmd_rt.ServoError):
            loop.set_position("knee", 1.0)
        loop.enable()
        loop.sleep(0.05)
        assert loop.state()["joints"]["knee"]["mode"] == "hold"
    finally:
        loop.stop()


def test_a_real_time_loop_runs_or_ends_safe_whatever_the_load(leg4):
    # Real time: the one placement that depends on the OS running the loop thread on time. A
    # busy machine (a build beside the tests) can keep the loop thread from running for longer
    # than leg4's stall bound (50 ms), even at start, and the loop then rightly ends with a
    # fault; the bounds here are those of a desktop rather than a robot (the stall detector has
    # its own tests in rmd-loop). Whether it runs on or ends on a fault, every motor ends off.
    text = leg4.read_text().replace(
        "[loop]\n", "[loop]\nstall_bound_ms = 2000\nmissing_reply_fault_after = 2000\n", 1
    )
    loop = rmd_rt.Robot.from_toml_str(text).start(sim=True)
    assert loop.placement == "simulated motors, real time"
    sim = loop.simulator()
    try:
        loop.set_velocity("knee", 0.4)
        loop.sleep(0.3)
    except rmd_rt.LoopStoppedError:
        pass
    report = loop.stop()
    assert report["normal_stop"] or "FAULT" in report["stop_reason"], report["stop_reason"]
    assert all(m["off_confirmed"] for m in report["safe_stop"]["motors"]), report["safe_stop"]
    assert sim.all_safe() and [m["mode"] for m in sim.motors()] == ["off"] * 4


def test_estop_ends_the_loop_with_the_motors_off(leg4):
    loop = rmd_rt.Robot.from_toml(leg4).start(sim=True, virtual_time=True)
    sim = loop.simulator()
    loop.set_velocity("knee", 0.5)
    loop.sleep(0.05)
    assert not sim.all_safe()
    loop.estop()
    report = loop.stop()
    assert not report["normal_stop"]
    reason = report["stop_reason"].lower()
    assert "emergency stop" in reason or "estop" in reason, reason
    assert sim.all_safe()
    assert [m["mode"] for m in sim.motors()] == ["off"] * 4
    with pytest.raises(rmd_rt.LoopStoppedError):
        loop.set_position("knee", 1.0)
    assert loop.stop() == report  # the same report again


def test_start_errors_are_clear(leg4):
    robot = rmd_rt.Robot.from_toml(leg4)
    with pytest.raises(rmd_rt.ConfigError, match="virtual"):
        robot.start(virtual_time=True, iface="vcan-none")
    with pytest.raises(rmd_rt.ConfigError, match="kp_nm_per_rad"):
        robot.start(sim=True, servo_toml="[defaults]\nkp_nm_per_rad = -1.0\n")
    with pytest.raises(rmd_rt.ConfigError, match="toe"):
        robot.start(sim=True, sim_initial_deg={"toe": 1.0})
    with pytest.raises(rmd_rt.ConfigError):
        rmd_rt.Robot.from_toml_str("[[bus]]\ninterface = 'can0'\n[[bus.motor]]\nid = 33\n")


def test_mcap_recording_switched_on_and_off_from_python(leg4, tmp_path):
    from mcap.reader import make_reader

    path = tmp_path / "run.mcap"
    loop = rmd_rt.Robot.from_toml(leg4).start(sim=True, virtual_time=True)
    try:
        loop.sleep(0.1)  # not recorded
        switched_on = loop.loop_time_s()
        loop.record_mcap(path)
        with pytest.raises(rmd_rt.TelemetryError, match="being written"):
            loop.record_mcap(tmp_path / "second.mcap")
        loop.move_to({"knee": 1.2}, 0.3)
        loop.sleep(0.5)
        status = loop.telemetry_status()
        assert status["mcap"]["path"] == str(path) and status["live"] is None
        counts = loop.stop_mcap()
        switched_off = loop.loop_time_s()
        loop.sleep(0.1)  # not recorded either
        stats = loop.stats()
    finally:
        loop.stop()
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {c.topic for c in summary.channels.values()}
        assert "/joint_states" in topics
        stamps = [
            m.log_time * 1e-9 for _, c, m in reader.iter_messages() if c.topic == "/joint_states"
        ]
    # One /joint_states message per recorded tick, every one between the switch-on and the
    # switch-off (not the 0.1 s before nor the 0.1 s after): the ticks of at least the 0.5 s
    # slept in between, at 1 kHz. The loop runs in virtual time, as fast as the CPU allows: on a
    # busy machine the telemetry may drop ticks (counted, at the loop or in the pipeline),
    # never take ticks from outside the window.
    assert counts["errors"] == 0
    assert len(stamps) == counts["written"] > 0
    assert counts["written"] + counts["dropped"] + counts["intake_dropped"] == counts["offered"]
    assert counts["offered"] + stats["telemetry_drops"] >= 500, (counts, stats)
    assert stamps == sorted(stamps)
    assert stamps[-1] - stamps[0] <= switched_off - switched_on + 0.0015


def test_live_foxglove_server_switched_on_from_python(leg4):
    import websockets

    loop = rmd_rt.Robot.from_toml(leg4).start(sim=True, virtual_time=True)
    try:
        addr = loop.serve_live("127.0.0.1:0", rate_hz=50.0)
        host, port = addr.rsplit(":", 1)
        assert host == "127.0.0.1" and int(port) > 0

        async def first_messages() -> list:
            uri = f"ws://{addr}"
            async with websockets.connect(uri, subprotocols=["foxglove.sdk.v1"]) as ws:
                messages = []
                while len(messages) < 2:
                    message = await asyncio.wait_for(ws.recv(), timeout=10)
                    if isinstance(message, str):
                        messages.append(json.loads(message))
                return messages

        messages = asyncio.run(first_messages())
        ops = [m.get("op") for m in messages]
        assert ops[0] == "serverInfo"
        assert "advertise" in ops
        advertised = {c["topic"] for m in messages if m.get("op") == "advertise" for c in m["channels"]}
        assert "/joint_states" in advertised
        assert loop.stop_live() is not None
        assert loop.telemetry_status()["live"] is None
    finally:
        loop.stop()
