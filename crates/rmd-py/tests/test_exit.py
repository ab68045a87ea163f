"""The motors are made safe when the program forgets to stop its loop: the object dropped, or
the interpreter exiting (normally or on an uncaught exception). Checked with the simulator's
ground truth, read after rmd_rt's own exit hook has run."""

from __future__ import annotations

import gc
import json
import subprocess
import sys
import textwrap

import pytest

import rmd_rt

PROGRAM = """
import atexit, json, sys

sim = None

def after_rmd_rt():
    # Registered before rmd_rt is imported, so it runs after rmd_rt's exit hook.
    print("AFTER " + json.dumps(sim.motors()), flush=True)

atexit.register(after_rmd_rt)

import rmd_rt

# The velocity setpoint never goes stale: virtual time runs tens of times faster than the wall
# clock, so a few ms of a loaded host between two lines here are a stale timeout's worth of loop
# time, and a stale knee brakes to a hold, its torque passing through zero on the way.
loop = rmd_rt.Robot.from_toml({leg4!r}).start(
    sim=True, virtual_time=True, servo_toml='[defaults]\\nstale_policy = "never"\\n'
)
sim = loop.simulator()
loop.set_velocity("knee", 0.2)
# Energised within 2 s of loop time (how soon depends on the start-up, not on the exit).
for _ in range(200):
    loop.sleep(0.01)
    before = sim.motors()
    if [m for m in before if m["joint"] == "knee"][0]["energising"]:
        break
print("BEFORE " + json.dumps(before), flush=True)
{ending}
"""


def motors(output: str, tag: str) -> list:
    (line,) = [l for l in output.splitlines() if l.startswith(tag + " ")]
    return json.loads(line[len(tag) + 1 :])


@pytest.mark.parametrize("ending", ["sys.exit(0)", "raise RuntimeError('crash')", "pass"])
def test_exiting_without_stopping_turns_the_motors_off(leg4, ending):
    program = PROGRAM.format(leg4=str(leg4), ending=ending)
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(program)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert ("crash" in out.stderr) == ("raise" in ending), out.stderr
    before = motors(out.stdout, "BEFORE")
    after = motors(out.stdout, "AFTER")
    # Running: the knee commanded torque to turn (joints held exactly in place may be at zero).
    (knee,) = [m for m in before if m["joint"] == "knee"]
    assert knee["energising"] and knee["mode"] == "torque", knee
    # After exit: every motor off and safe, as the simulator's firmware knows it.
    assert [m["mode"] for m in after] == ["off"] * 4, after
    assert all(m["safe"] and not m["energising"] for m in after), after


def test_dropping_the_loop_turns_the_motors_off(leg4):
    loop = rmd_rt.Robot.from_toml(leg4).start(sim=True, virtual_time=True)
    sim = loop.simulator()
    loop.set_velocity("knee", 0.4)
    loop.sleep(0.05)
    assert not sim.all_safe()
    del loop
    gc.collect()
    assert sim.all_safe()
    assert [m["mode"] for m in sim.motors()] == ["off"] * 4
