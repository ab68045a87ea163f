"""Type stubs of the native module (Rust, pyo3). Import ``rmd_rt``, not this."""

from os import PathLike
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

# The exceptions are rmd_rt._errors' (Python classes the native module raises). The TypedDicts
# and aliases below describe the dicts the module returns: they exist for type checkers only
# (tests/python/stubtest-allowlist.txt names them for mypy's stubtest).

__all__ = [
    "__version__",
    "NativeBus",
    "Robot",
    "RobotLoop",
    "Simulator",
    "Trajectory",
    "decode",
    "encode",
    "plan",
    "stop_all_loops",
]

__version__: str

Direction = Literal["auto", "request", "reply"]

def encode(
    command: str,
    id: Optional[int] = None,
    protocol: str = "v1.61",
    lk_series: Optional[str] = None,
    **fields: Any,
) -> str:
    """One command as a frame in candump's compact form (``141#A100000064000000``), exactly as
    ``rmd encode`` prints it. ``command`` is the ``rmd encode`` subcommand (``"torque"``,
    ``"position-4"``, ...); ``fields`` its flags in snake case (``iq_control=100``,
    ``amps=1.6``, ``deg=90.0``, ``spin_direction="cw"``, ...). Raises :class:`ProtocolError`
    with ``rmd encode``'s message for a value out of range."""

def decode(
    line: str,
    direction: Direction = "auto",
    protocol: str = "v1.61",
    lk_series: Optional[str] = None,
    encoder_bits: int = 14,
) -> Dict[str, Any]:
    """One candump line to the object ``rmd decode`` prints for it (``"auto"``: a line on its
    own is a request; ``"reply"`` for a motor's answer). Fields out of range are left out and
    named under ``"errors"``; an unreadable frame raises :class:`ProtocolError`."""

@final
class NativeBus:
    @staticmethod
    def socketcan(
        iface: str,
        protocol: str = "v1.61",
        lk_series: Optional[str] = None,
        encoder_bits: int = 14,
        timeout_s: float = 0.05,
        retries: int = 2,
    ) -> NativeBus: ...
    @staticmethod
    def simulated(
        ids: Sequence[int],
        virtual_time: bool = False,
        seed: int = 1,
        protocol: str = "v1.61",
        lk_series: Optional[str] = None,
        encoder_bits: int = 14,
        timeout_s: float = 0.05,
        retries: int = 2,
    ) -> NativeBus: ...
    def request(
        self,
        command: str,
        id: Optional[int] = None,
        fields: Optional[Mapping[str, Any]] = None,
        confirm_rom_write: bool = False,
    ) -> Any: ...
    def simulator(self) -> Optional[Simulator]: ...
    def now_s(self) -> float: ...

class SimMotion(TypedDict):
    position_rad: float
    velocity_rad_s: float
    kp_nm_per_rad: float
    kd_nm_s_per_rad: float
    torque_nm: float

class SimMotor(TypedDict):
    bus: int
    id: int
    joint: Optional[str]
    time_s: float
    motor_angle_deg: float
    output_angle_deg: float
    motor_speed_dps: float
    current_a: float
    output_torque_nm: float
    temperature_c: float
    voltage_v: float
    error_state: int
    mode: Literal["off", "torque", "speed", "position", "motion"]
    motion: Optional[SimMotion]
    stopped: bool
    energising: bool
    safe: bool
    pid_ram: Dict[str, int]
    pid_rom: Dict[str, int]

@final
class Simulator:
    """The simulated motors' ground truth (not what the bus reports)."""
    def motors(self) -> List[SimMotor]:
        """Every simulated motor's true state now."""
    def all_safe(self) -> bool:
        """Whether every simulated motor applies no torque and is commanded none."""

class BusInfo(TypedDict):
    name: str
    interface: str
    bitrate: int
    joints: List[str]

@final
class Robot:
    """A robot description (TOML), checked."""
    @staticmethod
    def from_toml(path: Union[str, PathLike[str]]) -> Robot:
        """Reads and checks the robot description at ``path``."""
    @staticmethod
    def from_toml_str(text: str) -> Robot:
        """Checks the robot description ``text``."""
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def rate_hz(self) -> float: ...
    @property
    def buses(self) -> List[BusInfo]: ...
    def start(
        self,
        sim: bool = False,
        iface: Union[None, str, Sequence[str]] = None,
        virtual_time: bool = False,
        servo_toml: Optional[str] = None,
        servo_file: Union[None, str, PathLike[str]] = None,
        seed: int = 1,
        sim_initial_deg: Optional[Mapping[str, float]] = None,
        start_timeout_s: float = 5.0,
    ) -> RobotLoop:
        """Starts the loop with the joint servo on its own Rust thread; returns once the servo
        published its first state. ``sim=True``: simulated motors; ``iface``: interfaces
        instead of the description's; ``virtual_time``: simulated motors in virtual time."""

class Reference(TypedDict):
    position_rad: float
    velocity_rad_s: float
    acceleration_rad_s2: float

class JointState(TypedDict):
    position_rad: float
    velocity_rad_s: float
    effort_nm: float
    fresh: bool
    received_at_s: float
    temperature_celsius: float
    current_amps: float
    mode: Literal["disabled", "zero-torque", "hold", "position", "velocity", "effort", "trajectory"]
    reference: Optional[Reference]
    effort_ff_nm: float
    commanded_effort_nm: float
    position_error_rad: Optional[float]
    stale: bool
    counters: Dict[str, int]

class LoopState(TypedDict):
    tick: int
    time_s: float
    enabled: bool
    estopped: bool
    joints: Dict[str, JointState]

class Receipt(TypedDict):
    duration_s: float
    max_lateness_s: float
    latest_joint: Optional[str]
    latest_point: Optional[int]

class SinkCounts(TypedDict, total=False):
    offered: int
    intake_dropped: int
    written: int
    dropped: int
    errors: int
    first_error: Optional[str]
    path: str
    addr: str

@final
class RobotLoop:
    """A running loop (from :meth:`Robot.start`); stopped with the motors made safe by
    ``stop()``, ``estop()``, dropping it, a ``with`` block's end, or the interpreter's exit."""
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def placement(self) -> str: ...
    def is_running(self) -> bool: ...
    def set_position(
        self, joint: str, position_rad: float, velocity_ff_rad_s: float = 0.0, effort_ff_nm: float = 0.0
    ) -> None: ...
    def set_velocity(self, joint: str, velocity_rad_s: float, effort_ff_nm: float = 0.0) -> None: ...
    def set_effort(self, joint: str, effort_nm: float) -> None: ...
    def set_positions(self, positions: Mapping[str, float]) -> None: ...
    def send_trajectory(
        self,
        joints: Sequence[str],
        times_s: Sequence[float],
        positions: Union[Sequence[Sequence[float]], npt.NDArray[np.float64]],
        velocities: Union[None, Sequence[Sequence[float]], npt.NDArray[np.float64]] = None,
        accelerations: Union[None, Sequence[Sequence[float]], npt.NDArray[np.float64]] = None,
        start_at_s: Optional[float] = None,
    ) -> Receipt: ...
    def move_to(self, targets: Mapping[str, float], duration_s: float) -> Receipt: ...
    def enable(self) -> None: ...
    def disable(self) -> None: ...
    def estop(self) -> None: ...
    def state(self) -> Optional[LoopState]: ...
    def positions(self) -> Optional[npt.NDArray[np.float64]]: ...
    def loop_time_s(self) -> Optional[float]: ...
    def sleep(self, seconds: float, timeout_s: Optional[float] = None) -> None: ...
    def stats(self, timeout_s: float = 0.5) -> Optional[Dict[str, Any]]: ...
    def stop(self) -> Dict[str, Any]: ...
    def simulator(self) -> Optional[Simulator]: ...
    def record_mcap(self, path: Union[str, PathLike[str]], compress: bool = True) -> None: ...
    def stop_mcap(self) -> Optional[SinkCounts]: ...
    def serve_live(self, addr: str = "127.0.0.1:8765", rate_hz: float = 100.0) -> str: ...
    def stop_live(self) -> Optional[SinkCounts]: ...
    def telemetry_status(self) -> Dict[str, Optional[SinkCounts]]: ...
    def __enter__(self) -> RobotLoop: ...
    def __exit__(self, *args: Any) -> bool: ...

class Samples(TypedDict):
    time: npt.NDArray[np.float64]
    position: npt.NDArray[np.float64]
    velocity: npt.NDArray[np.float64]
    acceleration: npt.NDArray[np.float64]
    jerk: npt.NDArray[np.float64]

@final
class Trajectory:
    """A trajectory calculated by :func:`plan`."""
    @property
    def dofs(self) -> int: ...
    @property
    def duration(self) -> float: ...
    @property
    def independent_min_durations(self) -> List[float]: ...
    @property
    def limiting_axis(self) -> Optional[int]: ...
    def sample(self, times: Union[Sequence[float], npt.NDArray[np.float64]]) -> Samples:
        """States at ``times``: arrays ``time`` (T,), ``position``/``velocity``/
        ``acceleration``/``jerk`` (T, dofs)."""
    def sample_every(self, dt: float) -> Samples:
        """States every ``dt`` s from 0 to the duration."""

def plan(
    current_position: Sequence[float],
    target_position: Sequence[float],
    max_velocity: Sequence[float],
    max_acceleration: Sequence[float],
    max_jerk: Sequence[float],
    *,
    current_velocity: Optional[Sequence[float]] = None,
    current_acceleration: Optional[Sequence[float]] = None,
    target_velocity: Optional[Sequence[float]] = None,
    target_acceleration: Optional[Sequence[float]] = None,
    min_velocity: Optional[Sequence[float]] = None,
    min_acceleration: Optional[Sequence[float]] = None,
    synchronization: Literal["time", "time-if-necessary", "phase", "none"] = "time",
    control_interface: Literal["position", "velocity"] = "position",
    minimum_duration: Optional[float] = None,
    period: Optional[float] = None,
) -> Trajectory:
    """A time-optimal, jerk-limited trajectory (rmd-traj) for 1..=16 axes."""

def stop_all_loops() -> None:
    """Stops every running loop (registered with atexit)."""
