"""rmd_rt: GYEMS / MyActuator RMD servo motors over CAN, from Python, with the real-time loop
in Rust.

- :func:`encode` / :func:`decode`: frames in candump's form, exactly as ``rmd encode`` and
  ``rmd decode`` make and read them;
- :class:`Bus` / :class:`AsyncBus`: every command of the protocol to one motor at a time, on
  SocketCAN or simulated motors, from several threads or from asyncio;
- :class:`Robot`: a robot description (TOML); :meth:`Robot.start` runs its loop with the joint
  servo on a Rust thread and returns a :class:`RobotLoop` to drive by joint name;
- :func:`plan`: time-optimal, jerk-limited trajectories sampled into NumPy arrays.

Every running loop is stopped, and its motors made safe, when its object is dropped or the
interpreter exits (an ``atexit`` hook registered on import). Every blocking call lets Ctrl-C
through (``KeyboardInterrupt``); every failure is an :class:`RmdError` (the hierarchy is in
``rmd_rt._errors``). See docs/python.md.
"""

from __future__ import annotations

import atexit

from . import _native
from ._bus import AsyncBus, Bus, Reply
from ._errors import (
    ArgumentError,
    BusError,
    ConfigError,
    ForkedProcessError,
    InternalError,
    LimitError,
    LoopError,
    LoopStoppedError,
    NoReplyError,
    ProtocolError,
    RmdError,
    RomWriteNotConfirmed,
    ServoError,
    SetpointError,
    TelemetryError,
    TrajectoryError,
)
from ._native import (
    Robot,
    RobotLoop,
    Simulator,
    Trajectory,
    decode,
    encode,
    plan,
)

__version__: str = _native.__version__
"""The package's version: the rmd-rt workspace's (the crate's Cargo version)."""

__all__ = [
    "ArgumentError",
    "AsyncBus",
    "Bus",
    "BusError",
    "ConfigError",
    "ForkedProcessError",
    "InternalError",
    "LimitError",
    "LoopError",
    "LoopStoppedError",
    "NoReplyError",
    "ProtocolError",
    "Reply",
    "RmdError",
    "Robot",
    "RobotLoop",
    "RomWriteNotConfirmed",
    "ServoError",
    "SetpointError",
    "Simulator",
    "TelemetryError",
    "Trajectory",
    "TrajectoryError",
    "__version__",
    "decode",
    "encode",
    "plan",
]

# The motors are made safe before the interpreter exits, even if the program never stopped its
# loops (a loop whose object is dropped earlier stops then).
atexit.register(_native.stop_all_loops)
