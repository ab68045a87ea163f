"""Bus: every command on simulated motors, checked against the simulator's ground truth; ROM
writes refused unless confirmed; several Python threads on one bus."""

from __future__ import annotations

import threading
import time

import pytest

import rmd_rt

PID = dict(
    angle_pid_kp=11, angle_pid_ki=12, speed_pid_kp=13, speed_pid_ki=14, iq_pid_kp=15, iq_pid_ki=16
)


def truth(bus: rmd_rt.Bus, id: int) -> dict:
    sim = bus.simulator()
    assert sim is not None
    (motor,) = [m for m in sim.motors() if m["id"] == id]
    return motor


def test_every_command_gets_its_reply():
    bus = rmd_rt.Bus.simulated([1, 2, 3, 4], virtual_time=True)
    calls = [
        (bus.read_status_1, (1,), {}, "read-status-1"),
        (bus.read_status_2, (2,), {}, "read-status-2"),
        (bus.read_status_3, (3,), {}, "read-status-3"),
        (bus.clear_error, (4,), {}, "clear-error"),
        (bus.read_multi_turn_angle, (1,), {}, "read-multi-turn-angle"),
        (bus.read_single_turn_angle, (1,), {}, "read-single-turn-angle"),
        (bus.read_encoder, (1,), {}, "read-encoder"),
        (bus.read_pid, (1,), {}, "read-pid"),
        (bus.read_accel, (1,), {}, "read-accel"),
        (bus.write_pid_ram, (1,), PID, "write-pid-ram"),
        (bus.write_accel_ram, (1,), {"accel": 5000}, "write-accel-ram"),
        (bus.write_encoder_offset, (1,), {"encoder_offset": 100}, "write-encoder-offset"),
        (bus.motor_run, (1,), {}, "motor-run"),
        (bus.torque, (1,), {"amps": 0.5}, "torque"),
        (bus.speed, (2,), {"dps": 360.0}, "speed"),
        (bus.position_1, (3,), {"deg": 90.0}, "position-1"),
        (bus.position_2, (3,), {"max_speed": 360, "deg": 0.0}, "position-2"),
        (bus.position_3, (4,), {"spin_direction": "cw", "deg": 10.0}, "position-3"),
        (bus.position_4, (4,), {"spin_direction": "ccw", "max_speed": 90, "deg": 0.0}, "position-4"),
        (bus.motor_stop, (1,), {}, "motor-stop"),
        (bus.motor_off, (1,), {}, "motor-off"),
    ]
    for call, args, kwargs, command in calls:
        reply = call(*args, **kwargs)
        assert reply["direction"] == "reply"
        assert reply["command"] == command, (call.__name__, reply)
        assert reply["id"] == args[0]
    assert bus.read_pid(1)["iq_pid_ki"] == 16
    assert bus.read_accel(1)["accel"] == 5000
    replies = bus.multi_torque(amps=[0.2, -0.2, 0.0, 0.1])
    assert [r["id"] for r in replies] == [1, 2, 3, 4]
    assert all(r["command"] == "torque" for r in replies)


def test_commands_act_on_the_simulated_motors():
    bus = rmd_rt.Bus.simulated([1], virtual_time=True)
    assert truth(bus, 1)["safe"]
    bus.torque(1, amps=1.0)
    assert truth(bus, 1)["mode"] == "torque" and truth(bus, 1)["energising"]
    bus.motor_off(1)
    assert truth(bus, 1)["mode"] == "off" and truth(bus, 1)["safe"]
    bus.speed(1, dps=720.0)
    start = bus.now_s()
    while bus.now_s() - start < 0.5:  # simulated time: settled at the target speed
        bus.read_status_2(1)
    reply = bus.read_status_2(1)
    assert reply["speed_dps"] == pytest.approx(720.0, abs=30.0)
    assert truth(bus, 1)["motor_speed_dps"] == pytest.approx(720.0, abs=30.0)
    bus.motor_off(1)


def test_rom_writes_need_confirmation_and_send_nothing_without_it():
    bus = rmd_rt.Bus.simulated([1], virtual_time=True)
    rom_before = truth(bus, 1)["pid_rom"]
    assert rom_before != PID
    with pytest.raises(rmd_rt.RomWriteNotConfirmed, match="confirm_rom_write=True"):
        bus.write_pid_rom(1, **PID)
    with pytest.raises(rmd_rt.RomWriteNotConfirmed):
        bus.request("write-pid-rom", 1, **PID)
    with pytest.raises(rmd_rt.RomWriteNotConfirmed, match="power cycle"):
        bus.write_zero_rom(1)
    assert truth(bus, 1)["pid_rom"] == rom_before
    reply = bus.write_pid_rom(1, confirm_rom_write=True, **PID)
    assert reply["command"] == "write-pid-rom"
    assert truth(bus, 1)["pid_rom"] == PID
    assert bus.write_zero_rom(1, confirm_rom_write=True)["command"] == "write-zero-rom"


def test_a_missing_motor_is_a_no_reply_error_with_advice():
    bus = rmd_rt.Bus.simulated([1], virtual_time=True, timeout_s=0.01, retries=1)
    with pytest.raises(rmd_rt.NoReplyError, match=r"motor 5 did not answer .* \(2 attempts\)"):
        bus.read_status_1(5)
    with pytest.raises(rmd_rt.ProtocolError):
        bus.torque(1, amps=99.0)
    with pytest.raises(rmd_rt.ConfigError):
        rmd_rt.Bus.simulated([40])


def test_several_threads_share_one_bus():
    bus = rmd_rt.Bus.simulated([1, 2, 3, 4])
    errors = []
    counts = [0] * 4

    def worker(k: int) -> None:
        id = k + 1
        try:
            for n in range(40):
                reply = bus.read_status_2(id) if n % 2 else bus.read_encoder(id)
                if reply["id"] != id:
                    errors.append(f"thread {id} got motor {reply['id']}'s reply")
                expected = "read-status-2" if n % 2 else "read-encoder"
                if reply["command"] != expected:
                    errors.append(f"thread {id} asked {expected}, got {reply['command']}")
                counts[k] += 1
        except Exception as error:  # noqa: BLE001 - reported below
            errors.append(repr(error))

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert not errors, errors[:5]
    assert counts == [40] * 4


def test_the_gil_is_released_while_waiting():
    # A request to a motor that is not there waits 2 x 0.2 s in Rust; meanwhile another Python
    # thread must keep running.
    bus = rmd_rt.Bus.simulated([1], timeout_s=0.2, retries=1)
    ticks = 0
    done = threading.Event()

    def counter() -> None:
        nonlocal ticks
        while not done.is_set():
            ticks += 1

    thread = threading.Thread(target=counter)
    thread.start()
    time.sleep(0.02)
    before = ticks
    with pytest.raises(rmd_rt.NoReplyError):
        bus.read_status_1(9)
    during = ticks - before
    done.set()
    thread.join()
    # Millions of iterations in 0.4 s on an idle machine, thousands under heavy load; a GIL
    # held by the waiting thread would allow none.
    assert during > 1000, during
