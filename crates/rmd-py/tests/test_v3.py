"""MyActuator V3 robots from Python: a description with V3 motors starts on the per-motor
exchange, follows setpoints, and stops with every motor safe by the simulator's ground truth."""

from __future__ import annotations

import math

import pytest

import rmd_rt
from conftest import REPO, STIFF_SERVO

LEG4_V3 = REPO / "examples" / "robots" / "leg4-v3.toml"


def test_a_v3_leg_follows_setpoints_and_ends_safe():
    robot = rmd_rt.Robot.from_toml(LEG4_V3)
    with robot.start(sim=True, virtual_time=True, servo_toml=STIFF_SERVO) as loop:
        loop.set_positions({"knee": 1.3, "hip_fe": -0.3})
        loop.sleep(1.0)
        positions = dict(zip(loop.joint_names, loop.positions()))
        # V3 motors report whole degrees at the output: 1 degree is 0.0175 rad.
        assert positions["knee"] == pytest.approx(1.3, abs=0.03)
        assert positions["hip_fe"] == pytest.approx(-0.3, abs=0.03)
        sim = loop.simulator()
        assert sim is not None
        truth = {m["joint"]: math.radians(m["output_angle_deg"]) for m in sim.motors()}
        assert truth["knee"] == pytest.approx(1.3, abs=0.03), truth
        report = loop.stop()
    assert report["normal_stop"], report["stop_reason"]
    assert all(m["off_confirmed"] for m in report["safe_stop"]["motors"])
    assert loop.simulator().all_safe()


def test_a_v3_leg_in_motion_mode_runs_the_servos_law_in_its_motors(tmp_path):
    # leg4-v3.toml with both buses exchanging in motion mode (0x400 + id).
    text = LEG4_V3.read_text()
    assert text.count('exchange = "per-motor"') == 2
    path = tmp_path / "leg4-v3-motion.toml"
    path.write_text(text.replace('exchange = "per-motor"', 'exchange = "motion"'))
    robot = rmd_rt.Robot.from_toml(path)
    with robot.start(sim=True, virtual_time=True, servo_toml=STIFF_SERVO) as loop:
        loop.set_positions({"knee": 1.3, "hip_fe": -0.3})
        loop.sleep(1.0)
        positions = dict(zip(loop.joint_names, loop.positions()))
        # Motion-mode replies carry 16-bit positions: finer than per-motor's whole degrees.
        assert positions["knee"] == pytest.approx(1.3, abs=0.01)
        assert positions["hip_fe"] == pytest.approx(-0.3, abs=0.01)
        motors = {m["joint"]: m for m in loop.simulator().motors()}
        for joint, target in (("knee", 1.3), ("hip_fe", -0.3)):
            m = motors[joint]
            # The firmware obeys motion-mode commands with the servo's own gains (STIFF_SERVO:
            # kp 80 N*m/rad, kd 2 N*m*s/rad) on the target, from the motor's zero.
            assert m["mode"] == "motion", m
            motion = m["motion"]
            assert motion["kp_nm_per_rad"] == pytest.approx(80.0, abs=0.2), motion
            assert motion["kd_nm_s_per_rad"] == pytest.approx(2.0, abs=0.01), motion
            zero = {"knee": -40.0, "hip_fe": 50.0}[joint]
            assert motion["position_rad"] == pytest.approx(
                target + math.radians(zero), abs=1e-3
            ), motion
            assert math.radians(m["output_angle_deg"]) == pytest.approx(target, abs=0.01), m
        # The joints not commanded hold where they were, in motion mode too.
        for m in motors.values():
            assert m["mode"] == "motion" and m["motion"]["kp_nm_per_rad"] > 79, m
        report = loop.stop()
    assert report["normal_stop"], report["stop_reason"]
    assert loop.simulator().all_safe()


def test_a_bus_of_v3_motors_speaks_their_protocol_by_the_ground_truth():
    bus = rmd_rt.Bus.simulated([1, 2], virtual_time=True, protocol="myactuator-v3")
    reply = bus.read_status_1(2)
    assert (reply["id"], reply["can_id"], reply["command"]) == (2, "0x242", "read-status-1")
    # V3's torque command: 0.01 A per unit (V4.3 §2.19), answered on 0x240 + id.
    assert rmd_rt.encode("torque", id=1, amps=1.0, protocol="myactuator-v3") == "141#A100000064000000"
    reply = bus.torque(1, amps=1.0)
    assert (reply["can_id"], reply["command"]) == ("0x241", "torque")
    motor = [m for m in bus.simulator().motors() if m["id"] == 1][0]
    assert motor["mode"] == "torque" and motor["energising"], motor
    bus.motor_off(1)
    motor = [m for m in bus.simulator().motors() if m["id"] == 1][0]
    assert motor["mode"] == "off" and motor["safe"], motor
    # A 0x280 frame is one command to every V3 motor, never torque: refused before sending.
    with pytest.raises(rmd_rt.ProtocolError, match="0x280 .* not part of protocol myactuator-v3"):
        bus.multi_torque(amps=[0.5, 0.5, 0.0, 0.0])
    assert all(m["safe"] for m in bus.simulator().motors())
