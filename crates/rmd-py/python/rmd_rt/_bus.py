"""One bus of RMD motors for per-motor commands: :class:`Bus` (threads) and :class:`AsyncBus`
(asyncio)."""

from __future__ import annotations

import asyncio
import functools
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Awaitable, Callable, Dict, List, Literal, Optional, Sequence, TypeVar

from . import _native

Reply = Dict[str, Any]
"""A motor's reply: the dict :func:`rmd_rt.decode` returns for it (``id``, ``can_id``,
``direction``, ``command``, then each field's raw value and physical values)."""

Spin = Literal["cw", "ccw"]
T = TypeVar("T")


class Bus:
    """One CAN bus of RMD motors: every command of the protocol, one request and its reply at
    a time.

    Open it with :meth:`socketcan` (a SocketCAN interface) or :meth:`simulated` (simulated
    motors in this process). Each method sends one request to motor ``id`` (1..=32) and
    returns its reply as a dict with the keys of :func:`rmd_rt.decode`; it raises
    :class:`rmd_rt.NoReplyError` when the motor does not answer within ``timeout_s`` after
    ``retries`` more tries, :class:`rmd_rt.ProtocolError` for a value out of range (nothing is
    sent) and :class:`rmd_rt.BusError` when the bus fails.

    Safe to call from several threads: the bus is behind a mutex in Rust, one exchange at a
    time, and the GIL is released while waiting, so other Python threads run meanwhile.

    Commands that write the motor's ROM (:meth:`write_pid_rom`, :meth:`write_zero_rom`) wear
    its flash and are sent only with ``confirm_rom_write=True``; otherwise they raise
    :class:`rmd_rt.RomWriteNotConfirmed` and send nothing.

    These commands are for set-up, diagnosis and slow moves. For control at a fixed rate, run
    the loop instead (:meth:`rmd_rt.Robot.start`): it commands every motor in one frame per
    tick from a Rust thread.
    """

    def __init__(self, native: _native.NativeBus, encoder_bits: int = 14) -> None:
        """Wraps a native bus; use :meth:`socketcan` or :meth:`simulated`."""
        self._native = native
        self.encoder_bits = encoder_bits

    @classmethod
    def socketcan(
        cls,
        iface: str,
        *,
        protocol: str = "v1.61",
        lk_series: Optional[str] = None,
        encoder_bits: int = 14,
        timeout_s: float = 0.05,
        retries: int = 2,
    ) -> "Bus":
        """Opens the SocketCAN interface ``iface`` (``"can0"``; it must be up at the motors'
        bit rate). ``protocol`` is ``"v1.61"`` (GYEMS / MyActuator RMD), ``"lk-v2.3x"``
        (LK-TECH, with ``lk_series="mf"`` or ``"mg"``) or ``"myactuator-v3"`` (MyActuator V3
        firmware: replies on 0x240 + id, no 0x280 torque frame); ``encoder_bits`` the motors' encoder
        width (12..=18); ``timeout_s`` the wait for each reply; ``retries`` how often a
        request is sent again after a timeout."""
        native = _native.NativeBus.socketcan(
            iface, protocol, lk_series, encoder_bits, timeout_s, retries
        )
        return cls(native, encoder_bits)

    @classmethod
    def simulated(
        cls,
        ids: Sequence[int] = (1,),
        *,
        virtual_time: bool = False,
        seed: int = 1,
        protocol: str = "v1.61",
        lk_series: Optional[str] = None,
        encoder_bits: int = 14,
        timeout_s: float = 0.05,
        retries: int = 2,
    ) -> "Bus":
        """Simulated motors ``ids`` in this process (rmd-sim: firmware, physics, the CAN wire),
        in real time or in ``virtual_time`` (each wait advances the simulator's clock at once).
        :meth:`simulator` shows their true state."""
        native = _native.NativeBus.simulated(
            list(ids), virtual_time, seed, protocol, lk_series, encoder_bits, timeout_s, retries
        )
        return cls(native, encoder_bits)

    def request(
        self,
        command: str,
        id: Optional[int] = None,
        *,
        confirm_rom_write: bool = False,
        **fields: Any,
    ) -> Any:
        """Sends any command by its ``rmd encode`` name with its fields (as :func:`rmd_rt.encode`
        takes them) and returns the reply (a list of four for ``"multi-torque"``)."""
        return self._native.request(command, id, fields, confirm_rom_write)

    def simulator(self) -> Optional[_native.Simulator]:
        """The simulated motors' true state (None on SocketCAN)."""
        return self._native.simulator()

    def now_s(self) -> float:
        """The bus clock, s (the simulator's clock in virtual time)."""
        return self._native.now_s()

    # Readings.
    def read_status_1(self, id: int) -> Reply:
        """0x9A: temperature, voltage, error flags."""
        return self.request("read-status-1", id)

    def read_status_2(self, id: int) -> Reply:
        """0x9C: temperature, torque current, speed, encoder."""
        return self.request("read-status-2", id)

    def read_status_3(self, id: int) -> Reply:
        """0x9D: phase currents."""
        return self.request("read-status-3", id)

    def clear_error(self, id: int) -> Reply:
        """0x9B: clears the error flags; the reply is status 1."""
        return self.request("clear-error", id)

    def read_multi_turn_angle(self, id: int) -> Reply:
        """0x92: the multi-turn angle (motor side)."""
        return self.request("read-multi-turn-angle", id)

    def read_single_turn_angle(self, id: int) -> Reply:
        """0x94: the single-turn angle (motor side)."""
        return self.request("read-single-turn-angle", id)

    def read_encoder(self, id: int) -> Reply:
        """0x90: encoder position, raw position and offset."""
        return self.request("read-encoder", id)

    def read_pid(self, id: int) -> Reply:
        """0x30: the PID gains in RAM."""
        return self.request("read-pid", id)

    def read_accel(self, id: int) -> Reply:
        """0x33: the acceleration, dps/s."""
        return self.request("read-accel", id)

    # Settings.
    def write_pid_ram(
        self,
        id: int,
        *,
        angle_pid_kp: int,
        angle_pid_ki: int,
        speed_pid_kp: int,
        speed_pid_ki: int,
        iq_pid_kp: int,
        iq_pid_ki: int,
    ) -> Reply:
        """0x31: writes the PID gains (0..=255 each) to RAM (lost at power-off)."""
        return self.request(
            "write-pid-ram",
            id,
            angle_pid_kp=angle_pid_kp,
            angle_pid_ki=angle_pid_ki,
            speed_pid_kp=speed_pid_kp,
            speed_pid_ki=speed_pid_ki,
            iq_pid_kp=iq_pid_kp,
            iq_pid_ki=iq_pid_ki,
        )

    def write_pid_rom(
        self,
        id: int,
        *,
        angle_pid_kp: int,
        angle_pid_ki: int,
        speed_pid_kp: int,
        speed_pid_ki: int,
        iq_pid_kp: int,
        iq_pid_ki: int,
        confirm_rom_write: bool = False,
    ) -> Reply:
        """0x32: writes the PID gains to ROM (flash, which wears out): only with
        ``confirm_rom_write=True``."""
        return self.request(
            "write-pid-rom",
            id,
            confirm_rom_write=confirm_rom_write,
            angle_pid_kp=angle_pid_kp,
            angle_pid_ki=angle_pid_ki,
            speed_pid_kp=speed_pid_kp,
            speed_pid_ki=speed_pid_ki,
            iq_pid_kp=iq_pid_kp,
            iq_pid_ki=iq_pid_ki,
        )

    def write_accel_ram(self, id: int, accel: int) -> Reply:
        """0x34: writes the acceleration (dps/s) to RAM."""
        return self.request("write-accel-ram", id, accel=accel)

    def write_encoder_offset(
        self, id: int, encoder_offset: int, *, confirm_rom_write: bool = False
    ) -> Reply:
        """0x91: writes the encoder offset (0..2^encoder_bits-1). On LK-TECH firmware this
        writes ROM (the motor's zero, kept over power cycles): there only with
        ``confirm_rom_write=True``."""
        return self.request(
            "write-encoder-offset",
            id,
            confirm_rom_write=confirm_rom_write,
            encoder_offset=encoder_offset,
            encoder_bits=self.encoder_bits,
        )

    def write_zero_rom(self, id: int, *, confirm_rom_write: bool = False) -> Reply:
        """0x19: writes the current position to ROM as the motor's zero (flash; takes effect
        after a power cycle): only with ``confirm_rom_write=True``."""
        return self.request("write-zero-rom", id, confirm_rom_write=confirm_rom_write)

    # Motion.
    def motor_off(self, id: int) -> Reply:
        """0x80: motor off (output disabled, state cleared)."""
        return self.request("motor-off", id)

    def motor_stop(self, id: int) -> Reply:
        """0x81: motor stop (output held off, state kept)."""
        return self.request("motor-stop", id)

    def motor_run(self, id: int) -> Reply:
        """0x88: motor run (resumes after a stop)."""
        return self.request("motor-run", id)

    def torque(
        self, id: int, *, amps: Optional[float] = None, iq_control: Optional[int] = None
    ) -> Reply:
        """0xA1: torque current, ``amps`` (A) or raw ``iq_control``; the reply is status 2."""
        return self.request("torque", id, amps=amps, iq_control=iq_control)

    def speed(
        self, id: int, *, dps: Optional[float] = None, speed_control: Optional[int] = None
    ) -> Reply:
        """0xA2: speed, ``dps`` (motor side, deg/s) or raw ``speed_control`` (0.01 dps)."""
        return self.request("speed", id, dps=dps, speed_control=speed_control)

    def position_1(
        self, id: int, *, deg: Optional[float] = None, angle_control: Optional[int] = None
    ) -> Reply:
        """0xA3: multi-turn position, ``deg`` (motor side) or raw ``angle_control`` (0.01°)."""
        return self.request("position-1", id, deg=deg, angle_control=angle_control)

    def position_2(
        self,
        id: int,
        *,
        max_speed: int,
        deg: Optional[float] = None,
        angle_control: Optional[int] = None,
    ) -> Reply:
        """0xA4: multi-turn position with a speed limit ``max_speed`` (dps)."""
        return self.request(
            "position-2", id, max_speed=max_speed, deg=deg, angle_control=angle_control
        )

    def position_3(
        self,
        id: int,
        *,
        spin_direction: Spin,
        deg: Optional[float] = None,
        angle_control: Optional[int] = None,
    ) -> Reply:
        """0xA5: single-turn position (0..<360°) turning ``spin_direction``."""
        return self.request(
            "position-3",
            id,
            spin_direction=spin_direction,
            deg=deg,
            angle_control=angle_control,
        )

    def position_4(
        self,
        id: int,
        *,
        spin_direction: Spin,
        max_speed: int,
        deg: Optional[float] = None,
        angle_control: Optional[int] = None,
    ) -> Reply:
        """0xA6: single-turn position with direction and speed limit."""
        return self.request(
            "position-4",
            id,
            spin_direction=spin_direction,
            max_speed=max_speed,
            deg=deg,
            angle_control=angle_control,
        )

    def multi_torque(
        self,
        *,
        amps: Optional[Sequence[float]] = None,
        iq_control: Optional[Sequence[int]] = None,
    ) -> List[Optional[Reply]]:
        """0x280: torque currents of motors 1..=4 in one frame; their replies (None for a motor
        that did not answer within the timeout)."""
        return self.request(
            "multi-torque",
            amps=None if amps is None else list(amps),
            iq_control=None if iq_control is None else list(iq_control),
        )

    def __repr__(self) -> str:
        return repr(self._native)


class AsyncBus:
    """:class:`Bus` for asyncio: the same methods, as coroutines.

    Each call runs the blocking exchange on a small thread pool (``loop.run_in_executor``), so
    the event loop never blocks: the Rust side releases the GIL while it waits and keeps one
    exchange at a time on the bus. Close it (``await bus.aclose()`` or ``async with``) to shut
    the pool down.
    """

    def __init__(self, bus: Bus, *, workers: int = 4) -> None:
        """Wraps ``bus``; ``workers`` threads wait for replies at once (requests still go on the
        bus one at a time)."""
        self.bus = bus
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="rmd-rt-bus")

    @classmethod
    def socketcan(cls, iface: str, **options: Any) -> "AsyncBus":
        """:meth:`Bus.socketcan`, for asyncio."""
        return cls(Bus.socketcan(iface, **options))

    @classmethod
    def simulated(cls, ids: Sequence[int] = (1,), **options: Any) -> "AsyncBus":
        """:meth:`Bus.simulated`, for asyncio."""
        return cls(Bus.simulated(ids, **options))

    def _run(self, call: Callable[..., T], *args: Any, **kwargs: Any) -> Awaitable[T]:
        loop = asyncio.get_running_loop()
        return loop.run_in_executor(self._pool, functools.partial(call, *args, **kwargs))

    async def aclose(self) -> None:
        """Waits for the calls in flight and shuts the thread pool down."""
        await asyncio.get_running_loop().run_in_executor(None, self._pool.shutdown)

    async def __aenter__(self) -> "AsyncBus":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.aclose()

    def simulator(self) -> Optional[_native.Simulator]:
        """The simulated motors' true state (None on SocketCAN)."""
        return self.bus.simulator()

    async def request(
        self, command: str, id: Optional[int] = None, *, confirm_rom_write: bool = False,
        **fields: Any,
    ) -> Any:
        """:meth:`Bus.request`."""
        return await self._run(
            self.bus.request, command, id, confirm_rom_write=confirm_rom_write, **fields
        )

    async def read_status_1(self, id: int) -> Reply:
        """:meth:`Bus.read_status_1`."""
        return await self._run(self.bus.read_status_1, id)

    async def read_status_2(self, id: int) -> Reply:
        """:meth:`Bus.read_status_2`."""
        return await self._run(self.bus.read_status_2, id)

    async def read_status_3(self, id: int) -> Reply:
        """:meth:`Bus.read_status_3`."""
        return await self._run(self.bus.read_status_3, id)

    async def clear_error(self, id: int) -> Reply:
        """:meth:`Bus.clear_error`."""
        return await self._run(self.bus.clear_error, id)

    async def read_multi_turn_angle(self, id: int) -> Reply:
        """:meth:`Bus.read_multi_turn_angle`."""
        return await self._run(self.bus.read_multi_turn_angle, id)

    async def read_single_turn_angle(self, id: int) -> Reply:
        """:meth:`Bus.read_single_turn_angle`."""
        return await self._run(self.bus.read_single_turn_angle, id)

    async def read_encoder(self, id: int) -> Reply:
        """:meth:`Bus.read_encoder`."""
        return await self._run(self.bus.read_encoder, id)

    async def read_pid(self, id: int) -> Reply:
        """:meth:`Bus.read_pid`."""
        return await self._run(self.bus.read_pid, id)

    async def read_accel(self, id: int) -> Reply:
        """:meth:`Bus.read_accel`."""
        return await self._run(self.bus.read_accel, id)

    async def write_pid_ram(self, id: int, **gains: int) -> Reply:
        """:meth:`Bus.write_pid_ram`."""
        return await self._run(self.bus.write_pid_ram, id, **gains)

    async def write_pid_rom(self, id: int, *, confirm_rom_write: bool = False, **gains: int) -> Reply:
        """:meth:`Bus.write_pid_rom`."""
        return await self._run(
            self.bus.write_pid_rom, id, confirm_rom_write=confirm_rom_write, **gains
        )

    async def write_accel_ram(self, id: int, accel: int) -> Reply:
        """:meth:`Bus.write_accel_ram`."""
        return await self._run(self.bus.write_accel_ram, id, accel)

    async def write_encoder_offset(
        self, id: int, encoder_offset: int, *, confirm_rom_write: bool = False
    ) -> Reply:
        """:meth:`Bus.write_encoder_offset`."""
        return await self._run(
            self.bus.write_encoder_offset, id, encoder_offset, confirm_rom_write=confirm_rom_write
        )

    async def write_zero_rom(self, id: int, *, confirm_rom_write: bool = False) -> Reply:
        """:meth:`Bus.write_zero_rom`."""
        return await self._run(self.bus.write_zero_rom, id, confirm_rom_write=confirm_rom_write)

    async def motor_off(self, id: int) -> Reply:
        """:meth:`Bus.motor_off`."""
        return await self._run(self.bus.motor_off, id)

    async def motor_stop(self, id: int) -> Reply:
        """:meth:`Bus.motor_stop`."""
        return await self._run(self.bus.motor_stop, id)

    async def motor_run(self, id: int) -> Reply:
        """:meth:`Bus.motor_run`."""
        return await self._run(self.bus.motor_run, id)

    async def torque(
        self, id: int, *, amps: Optional[float] = None, iq_control: Optional[int] = None
    ) -> Reply:
        """:meth:`Bus.torque`."""
        return await self._run(self.bus.torque, id, amps=amps, iq_control=iq_control)

    async def speed(
        self, id: int, *, dps: Optional[float] = None, speed_control: Optional[int] = None
    ) -> Reply:
        """:meth:`Bus.speed`."""
        return await self._run(self.bus.speed, id, dps=dps, speed_control=speed_control)

    async def position_1(self, id: int, **target: Any) -> Reply:
        """:meth:`Bus.position_1`."""
        return await self._run(self.bus.position_1, id, **target)

    async def position_2(self, id: int, **target: Any) -> Reply:
        """:meth:`Bus.position_2`."""
        return await self._run(self.bus.position_2, id, **target)

    async def position_3(self, id: int, **target: Any) -> Reply:
        """:meth:`Bus.position_3`."""
        return await self._run(self.bus.position_3, id, **target)

    async def position_4(self, id: int, **target: Any) -> Reply:
        """:meth:`Bus.position_4`."""
        return await self._run(self.bus.position_4, id, **target)

    async def multi_torque(
        self,
        *,
        amps: Optional[Sequence[float]] = None,
        iq_control: Optional[Sequence[int]] = None,
    ) -> List[Optional[Reply]]:
        """:meth:`Bus.multi_torque`."""
        return await self._run(self.bus.multi_torque, amps=amps, iq_control=iq_control)
