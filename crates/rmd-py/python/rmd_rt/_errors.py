"""The exceptions of :mod:`rmd_rt`: one base, :class:`RmdError`, and one class per kind of
failure. The native module raises these classes (it imports them from here), so every failure of
the Rust side, a bug included, is an :class:`RmdError`: ``except rmd_rt.RmdError`` catches them
all, and nothing the package raises escapes ``except Exception``.

::

    RmdError
    ├── ArgumentError (also ValueError)       a value refused before anything acts
    │   ├── ProtocolError                     encode / decode
    │   ├── TrajectoryError                   plan
    │   └── SetpointError (also ServoError)   a setpoint or trajectory the servo refuses
    │       └── LimitError                    ... outside a joint's limits
    ├── ConfigError                           robot description, servo file, placement
    ├── BusError
    │   └── NoReplyError
    ├── RomWriteNotConfirmed
    ├── ServoError                            the servo cannot take it now (disabled, queue full)
    ├── LoopError                             the loop could not start
    │   └── LoopStoppedError                  the loop has ended: start a new one
    ├── ForkedProcessError                    an object of the parent used after os.fork()
    ├── TelemetryError
    └── InternalError                         a bug in rmd_rt (a Rust panic): please report it

Ctrl-C is not among them: it raises Python's own ``KeyboardInterrupt`` from every blocking call.
"""

from __future__ import annotations

__all__ = [
    "ArgumentError",
    "BusError",
    "ConfigError",
    "ForkedProcessError",
    "InternalError",
    "LimitError",
    "LoopError",
    "LoopStoppedError",
    "NoReplyError",
    "ProtocolError",
    "RmdError",
    "RomWriteNotConfirmed",
    "ServoError",
    "SetpointError",
    "TelemetryError",
    "TrajectoryError",
]


class RmdError(Exception):
    """Base class of every error rmd_rt raises. The message is the Rust error's: what is wrong
    and what to do."""


class ArgumentError(RmdError, ValueError):
    """A value given to rmd_rt was refused before anything acted: not a finite number (NaN,
    an infinity), out of range, or of the wrong shape. The message names the argument."""


class ProtocolError(ArgumentError):
    """A value that does not fit the protocol (encode), or a frame that cannot be read (decode);
    the message is the one ``rmd encode`` / ``rmd decode`` prints."""


class TrajectoryError(ArgumentError):
    """rmd-traj could not calculate a trajectory for the input (the message names the axis and
    the reason)."""


class ConfigError(RmdError):
    """A robot description, servo configuration or placement (sim / iface) is not valid."""


class BusError(RmdError):
    """The bus failed: it could not be opened, a frame could not be sent, or a motor answered
    with something unexpected."""


class NoReplyError(BusError):
    """A motor did not answer within the timeout, after every retry."""


class RomWriteNotConfirmed(RmdError):
    """A command that writes the motor's ROM (flash) was asked for without
    ``confirm_rom_write=True``; nothing was sent."""


class ServoError(RmdError):
    """The servo refused a request; nothing was sent. This class itself: the servo cannot take
    it now (disabled, its queue or trajectory buffers full, no state yet); the subclass
    :class:`SetpointError`: the request itself is wrong."""


class SetpointError(ServoError, ArgumentError):
    """The servo refused the setpoint or trajectory itself: an unknown or repeated joint, a
    value that is not a finite number, points that do not fit together, no jerk-limited motion
    reaching them. Nothing was sent."""


class LimitError(SetpointError):
    """A setpoint or trajectory point outside a joint's limits (the message names the joint,
    the value, the limits and where they are set). Nothing was sent."""


class LoopError(RmdError):
    """The real-time loop could not start (the message gives its report's reason)."""


class LoopStoppedError(LoopError):
    """The loop is no longer running (stopped, e-stopped, or ended on a fault, with the motors
    made safe), so it takes no more commands: ``stop()`` returns its report; start a new loop
    to go on."""


class ForkedProcessError(RmdError):
    """A loop, bus or simulator was used in a child process made by ``os.fork()``: it belongs
    to the process that made it (its threads and sockets live there). Make a new one in the
    child; the parent's keeps running, untouched."""


class TelemetryError(RmdError):
    """A telemetry sink (MCAP file, live Foxglove server) could not be started."""


class InternalError(RmdError):
    """A bug in rmd_rt: the Rust side panicked. The call did nothing more; a running loop and
    its supervisor are not affected. Please report it with the call and the message."""


for _cls in [globals()[_name] for _name in __all__]:
    # Shown as rmd_rt.X in tracebacks and reprs: the package's public names.
    _cls.__module__ = "rmd_rt"
del _cls
