"""The package when its user misbehaves: every failure an exception of rmd_rt's own hierarchy
(never pyo3's PanicException, a BaseException that `except Exception` misses); NaN, infinities
and absurd magnitudes in every float and duration argument refused with a ValueError of the
package; commands to a loop that has ended refused. Ctrl-C and os.fork() are in
test_interrupt.py."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List

import pytest

import rmd_rt
from conftest import LEG4

NOT_FINITE = [math.nan, math.inf, -math.inf]
# Finite but absurd: each must either work or be refused with an ArgumentError.
ABSURD = [1e300, -1e300, 1e-300, -1.0, 0.0, 1e19]

EXCEPTIONS = {
    "RmdError": (Exception,),
    "ArgumentError": ("RmdError", ValueError),
    "ProtocolError": ("ArgumentError",),
    "TrajectoryError": ("ArgumentError",),
    "SetpointError": ("ServoError", "ArgumentError"),
    "LimitError": ("SetpointError",),
    "ConfigError": ("RmdError",),
    "BusError": ("RmdError",),
    "NoReplyError": ("BusError",),
    "RomWriteNotConfirmed": ("RmdError",),
    "ServoError": ("RmdError",),
    "LoopError": ("RmdError",),
    "LoopStoppedError": ("LoopError",),
    "ForkedProcessError": ("RmdError",),
    "TelemetryError": ("RmdError",),
    "InternalError": ("RmdError",),
}


def test_the_exception_hierarchy():
    for name, bases in EXCEPTIONS.items():
        cls = getattr(rmd_rt, name)
        assert name in rmd_rt.__all__
        assert cls.__module__ == "rmd_rt" and cls.__doc__, name
        for base in bases:
            base = getattr(rmd_rt, base) if isinstance(base, str) else base
            assert issubclass(cls, base), (name, base)
        assert issubclass(cls, Exception), name
    # No exception class of the package is left out of the table.
    exported = {n for n in rmd_rt.__all__ if isinstance(getattr(rmd_rt, n), type)
                and issubclass(getattr(rmd_rt, n), BaseException)}
    assert exported == set(EXCEPTIONS)


@pytest.fixture
def loop():
    """leg4 in virtual time (deterministic, whatever the machine's load)."""
    loop = rmd_rt.Robot.from_toml(LEG4).start(sim=True, virtual_time=True)
    yield loop
    loop.stop()


@pytest.fixture
def bus():
    return rmd_rt.Bus.simulated([1, 2, 3, 4], virtual_time=True)


def robot_start(**options: Any) -> None:
    loop = rmd_rt.Robot.from_toml(LEG4).start(sim=True, virtual_time=True, **options)
    loop.stop()


def plan(**override: Any) -> rmd_rt.Trajectory:
    args: Dict[str, Any] = dict(
        current_position=[0.0], target_position=[1.0], max_velocity=[1.0],
        max_acceleration=[2.0], max_jerk=[10.0],
    )
    args.update(override)
    return rmd_rt.plan(**args)


def one(v: float) -> List[float]:
    return [v]


# Every float and duration argument of the package, as a call taking the value.
LOOP_CASES: Dict[str, Callable[[rmd_rt.RobotLoop, float], Any]] = {
    "set_position": lambda l, v: l.set_position("knee", v),
    "set_position velocity_ff": lambda l, v: l.set_position("knee", 1.0, velocity_ff_rad_s=v),
    "set_position effort_ff": lambda l, v: l.set_position("knee", 1.0, effort_ff_nm=v),
    "set_velocity": lambda l, v: l.set_velocity("knee", v),
    "set_velocity effort_ff": lambda l, v: l.set_velocity("knee", 0.0, effort_ff_nm=v),
    "set_effort": lambda l, v: l.set_effort("knee", v),
    "set_positions": lambda l, v: l.set_positions({"knee": v}),
    "send_trajectory times_s": lambda l, v: l.send_trajectory(["knee"], [v], [[1.0]]),
    "send_trajectory positions": lambda l, v: l.send_trajectory(["knee"], [0.5], [[v]]),
    "send_trajectory velocities": lambda l, v: l.send_trajectory(
        ["knee"], [0.5, 1.0], [[1.0], [1.1]], velocities=[[v], [0.0]]),
    "send_trajectory accelerations": lambda l, v: l.send_trajectory(
        ["knee"], [0.5, 1.0], [[1.0], [1.1]], accelerations=[[v], [0.0]]),
    "send_trajectory start_at_s": lambda l, v: l.send_trajectory(
        ["knee"], [0.5], [[1.0]], start_at_s=v),
    "move_to target": lambda l, v: l.move_to({"knee": v}, 1.0),
    "move_to duration_s": lambda l, v: l.move_to({"knee": 1.0}, v),
    "sleep": lambda l, v: l.sleep(v, timeout_s=0.5),
    "sleep timeout_s": lambda l, v: l.sleep(0.001, timeout_s=v),
    "stats timeout_s": lambda l, v: l.stats(timeout_s=v),
    "serve_live rate_hz": lambda l, v: (l.serve_live("127.0.0.1:0", rate_hz=v), l.stop_live()),
}

BUS_CASES: Dict[str, Callable[[rmd_rt.Bus, float], Any]] = {
    "torque amps": lambda b, v: b.torque(1, amps=v),
    "speed dps": lambda b, v: b.speed(1, dps=v),
    "position_1 deg": lambda b, v: b.position_1(1, deg=v),
    "position_2 deg": lambda b, v: b.position_2(1, max_speed=100, deg=v),
    "position_3 deg": lambda b, v: b.position_3(1, spin_direction="cw", deg=v),
    "position_4 deg": lambda b, v: b.position_4(1, spin_direction="cw", max_speed=100, deg=v),
    "multi_torque amps": lambda b, v: b.multi_torque(amps=[v, 0.0, 0.0, 0.0]),
}

OTHER_CASES: Dict[str, Callable[[float], Any]] = {
    "encode amps": lambda v: rmd_rt.encode("torque", id=1, amps=v),
    "encode dps": lambda v: rmd_rt.encode("speed", id=1, dps=v),
    "encode deg": lambda v: rmd_rt.encode("position-1", id=1, deg=v),
    "encode lk amps": lambda v: rmd_rt.encode(
        "torque", id=1, amps=v, protocol="lk-v2.3x", lk_series="mf"),
    "Bus.simulated timeout_s": lambda v: rmd_rt.Bus.simulated([1], timeout_s=v),
    "Robot.start start_timeout_s": lambda v: robot_start(start_timeout_s=v),
    "Robot.start sim_initial_deg": lambda v: robot_start(sim_initial_deg={"knee": v}),
    "plan current_position": lambda v: plan(current_position=one(v)),
    "plan target_position": lambda v: plan(target_position=one(v)),
    "plan max_velocity": lambda v: plan(max_velocity=one(v)),
    "plan max_acceleration": lambda v: plan(max_acceleration=one(v)),
    "plan max_jerk": lambda v: plan(max_jerk=one(v)),
    "plan current_velocity": lambda v: plan(current_velocity=one(v)),
    "plan current_acceleration": lambda v: plan(current_acceleration=one(v)),
    "plan target_velocity": lambda v: plan(target_velocity=one(v)),
    "plan target_acceleration": lambda v: plan(target_acceleration=one(v)),
    "plan min_velocity": lambda v: plan(min_velocity=one(v)),
    "plan min_acceleration": lambda v: plan(min_acceleration=one(v)),
    "plan minimum_duration": lambda v: plan(minimum_duration=v),
    "plan period": lambda v: plan(period=v),
    "Trajectory.sample": lambda v: plan().sample([v]),
    "Trajectory.sample_every": lambda v: plan().sample_every(v),
}


def check(call: Callable[[float], Any]) -> None:
    """NaN and the infinities are refused with an ArgumentError (a ValueError); absurd finite
    values work, or fail with one of the package's exceptions (an ArgumentError, or what the
    value leads to: a timeout, full trajectory buffers). A bug (InternalError), pyo3's
    PanicException or any other exception fails the test."""
    for v in NOT_FINITE:
        with pytest.raises(rmd_rt.ArgumentError):
            call(v)
    for v in ABSURD:
        try:
            call(v)
        except rmd_rt.InternalError:
            raise
        except rmd_rt.RmdError:
            pass


@pytest.mark.parametrize("case", sorted(LOOP_CASES))
def test_loop_arguments_are_refused_unless_finite_and_in_range(loop, case):
    check(lambda v: LOOP_CASES[case](loop, v))
    assert loop.is_running(), loop.stop()["stop_reason"]


@pytest.mark.parametrize("case", sorted(BUS_CASES))
def test_bus_arguments_are_refused_unless_finite_and_in_range(bus, case):
    check(lambda v: BUS_CASES[case](bus, v))


@pytest.mark.parametrize("case", sorted(OTHER_CASES))
def test_other_arguments_are_refused_unless_finite_and_in_range(case):
    check(OTHER_CASES[case])


def test_the_reported_reproductions_raise_value_errors(loop):
    # Each of these raised pyo3's PanicException, or returned at once, before.
    with pytest.raises(ValueError, match="timeout_s"):
        loop.stats(timeout_s=math.nan)
    with pytest.raises(ValueError, match="duration_s"):
        loop.move_to({"knee": 1.0}, 1e300)
    with pytest.raises(ValueError, match="times_s"):
        loop.send_trajectory(["knee"], [1e300], [[1.0]])
    with pytest.raises(ValueError, match="seconds"):
        loop.sleep(math.nan)
    with pytest.raises(ValueError, match="seconds"):
        loop.sleep(-1.0)
    with pytest.raises(ValueError, match="start_timeout_s"):
        rmd_rt.Robot.from_toml(LEG4).start(sim=True, start_timeout_s=math.nan)
    with pytest.raises(ValueError, match="retries"):
        rmd_rt.Bus.simulated([1], retries=-1)


def test_calls_on_a_stopped_loop_raise(tmp_path):
    loop = rmd_rt.Robot.from_toml(LEG4).start(sim=True, virtual_time=True)
    report = loop.stop()
    calls: Dict[str, Callable[[], Any]] = {
        "record_mcap": lambda: loop.record_mcap(tmp_path / "late.mcap"),
        "serve_live": lambda: loop.serve_live("127.0.0.1:0"),
        "set_position": lambda: loop.set_position("knee", 1.0),
        "set_velocity": lambda: loop.set_velocity("knee", 0.0),
        "set_effort": lambda: loop.set_effort("knee", 0.0),
        "set_positions": lambda: loop.set_positions({"knee": 1.0}),
        "send_trajectory": lambda: loop.send_trajectory(["knee"], [0.5], [[1.0]]),
        "move_to": lambda: loop.move_to({"knee": 1.0}, 0.5),
        "enable": loop.enable,
        "disable": loop.disable,
        "sleep": lambda: loop.sleep(0.01),
        "stats": loop.stats,
    }
    for name, call in calls.items():
        with pytest.raises(rmd_rt.LoopStoppedError, match="no longer running"):
            call()
        assert not (tmp_path / "late.mcap").exists(), name
    # What reads the end stays readable, and the final stop and e-stop do no harm.
    assert not loop.is_running()
    assert loop.state() is not None and loop.positions() is not None
    assert loop.telemetry_status() == {"mcap": None, "live": None}
    loop.estop()
    assert loop.stop() == report
    assert loop.simulator().all_safe()


def test_a_loop_that_ended_on_its_own_refuses_commands_too():
    loop = rmd_rt.Robot.from_toml(LEG4).start(sim=True, virtual_time=True)
    loop.estop()  # ends the loop; stop() not called
    while loop.is_running():
        pass
    with pytest.raises(rmd_rt.LoopStoppedError):
        loop.serve_live("127.0.0.1:0")
    with pytest.raises(rmd_rt.LoopStoppedError):
        loop.move_to({"knee": 1.0}, 0.5)
    assert not loop.stop()["normal_stop"]
