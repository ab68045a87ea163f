#!/usr/bin/env python3
"""Waves the four joints of examples/robots/leg4.toml: the loop and the joint servo run in Rust
on their own thread; this program sends a trajectory by joint name, watches the joints, and
stops. On simulated motors unless --iface is given (a demo never moves real motors by
surprise).

    pip install ./crates/rmd-py
    python examples/python/leg4_wave.py                      # simulated motors, real time
    python examples/python/leg4_wave.py --virtual-time       # as fast as the CPU allows
    python examples/python/leg4_wave.py --mcap wave.mcap     # telemetry for Foxglove
    python examples/python/leg4_wave.py --iface can0         # the real leg (careful)
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import rmd_rt

LEG4 = Path(__file__).resolve().parents[1] / "robots" / "leg4.toml"

# Gains for the unloaded simulated leg; tune them for a real one (docs/servo.md).
SERVO = """
[defaults]
kp_nm_per_rad = 60.0
kd_nm_s_per_rad = 1.5
max_velocity_rad_s = 2.0
"""


def wave(start: np.ndarray, cycles: int, period_s: float, amplitude_rad: float):
    """Points of a wave around `start`: each joint swings by `amplitude_rad`, a quarter period
    after the previous one, and the leg comes back to `start`."""
    times, points = [], []
    steps = 8
    for k in range(1, cycles * steps + 1):
        t = k * period_s / steps
        phase = 2 * math.pi * t / period_s
        offsets = [amplitude_rad * math.sin(phase - j * math.pi / 2) for j in range(len(start))]
        times.append(t)
        points.append(start + np.array(offsets))
    times.append(times[-1] + period_s / steps)
    points.append(start)
    return times, np.array(points)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", type=Path, default=LEG4, help="robot description (TOML)")
    parser.add_argument("--iface", help="SocketCAN interface(s) of the real leg (default: simulated)")
    parser.add_argument("--virtual-time", action="store_true", help="simulated motors in virtual time")
    parser.add_argument("--cycles", type=int, default=2, help="waves")
    parser.add_argument("--period", type=float, default=2.0, help="seconds per wave")
    parser.add_argument("--amplitude", type=float, default=0.25, help="rad")
    parser.add_argument("--mcap", type=Path, help="record the telemetry to this MCAP file")
    args = parser.parse_args()

    robot = rmd_rt.Robot.from_toml(args.robot)
    loop = robot.start(
        sim=args.iface is None,
        iface=args.iface,
        virtual_time=args.virtual_time,
        servo_toml=SERVO,
    )
    with loop:  # stops the loop (motors made safe) however the block ends
        print(f"{loop.placement}: joints {', '.join(loop.joint_names)}")
        if args.mcap:
            loop.record_mcap(args.mcap)
        start = loop.positions()
        assert start is not None  # the loop has published its first state: start() waits for it
        times, points = wave(start, args.cycles, args.period, args.amplitude)
        receipt = loop.send_trajectory(loop.joint_names, times, points)
        print(f"trajectory: {len(times)} points, {receipt['duration_s']:.2f} s")
        elapsed = 0.0
        while elapsed < receipt["duration_s"] + 0.3:
            loop.sleep(0.5)
            elapsed += 0.5
            state = loop.state()
            assert state is not None
            joints = state["joints"]
            line = "  ".join(
                f"{name} {math.degrees(j['position_rad']):+6.1f}°" for name, j in joints.items()
            )
            print(f"t={loop.loop_time_s():6.2f} s  {line}")
        end = loop.positions()
        assert end is not None
        error = np.abs(end - start).max()
        print(f"back at the start within {math.degrees(error):.2f}°")
        stats = loop.stats()
        if stats:
            print(
                f"ticks {stats['ticks']}, deadline misses {stats['deadline_misses']}, "
                f"missing replies {stats['missing_replies']}"
            )
        if args.mcap:
            counts = loop.stop_mcap()
            written = counts["written"] if counts else 0
            print(f"{args.mcap}: {written} ticks written")
        report = loop.stop()
    print(f"stopped: {report['stop_reason']}; every motor off: "
          f"{all(m['off_confirmed'] for m in report['safe_stop']['motors'])}")


if __name__ == "__main__":
    main()
