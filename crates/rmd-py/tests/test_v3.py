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
