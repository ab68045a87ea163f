"""The robot description's joint limits, from Python: a target beyond them is refused before
anything moves. The finding behind them: `loop.set_position("knee", 100.0)` (radians, where the
CLI speaks degrees) spun the simulated knee to 73 rad in 3 s. leg4.toml's knee turns 5..165
degrees; the servo configuration says nothing about positions."""

from __future__ import annotations

import math

import pytest

import rmd_rt


def test_a_target_beyond_the_descriptions_limits_is_refused_and_nothing_moves(leg4):
    robot = rmd_rt.Robot.from_toml(leg4)
    with robot.start(sim=True, virtual_time=True) as loop:
        start = dict(zip(loop.joint_names, loop.positions()))
        with pytest.raises(rmd_rt.ServoError, match=r"knee.*is 100,.*robot description: position_max_deg"):
            loop.set_position("knee", 100.0)
        with pytest.raises(rmd_rt.ServoError, match="knee"):
            loop.set_positions({"knee": 100.0, "ankle": -0.3})
        with pytest.raises(rmd_rt.ServoError, match="knee"):
            loop.move_to({"knee": 100.0}, 3.0)
        loop.sleep(3.0)
        sim = {m["joint"]: m for m in loop.simulator().motors()}
        # Ground truth: the knee did not move (0.5 degrees: the hold's friction band).
        knee = math.radians(sim["knee"]["output_angle_deg"])
        assert abs(knee - start["knee"]) < math.radians(0.5), (knee, start["knee"])
        # Within the limits it goes.
        loop.move_to({"knee": 1.5}, 1.0)
        loop.sleep(1.5)
        assert loop.positions()[loop.joint_names.index("knee")] == pytest.approx(1.5, abs=0.02)
