"""AsyncBus: the same commands as coroutines; the event loop keeps running while they wait."""

from __future__ import annotations

import asyncio

import pytest

import rmd_rt


def test_gathered_requests_get_their_own_replies():
    async def main() -> list:
        async with rmd_rt.AsyncBus.simulated([1, 2, 3, 4]) as bus:
            return await asyncio.gather(*(bus.read_status_2(id) for id in (1, 2, 3, 4, 1, 2)))

    replies = asyncio.run(main())
    assert [r["id"] for r in replies] == [1, 2, 3, 4, 1, 2]
    assert all(r["command"] == "read-status-2" for r in replies)


def test_the_event_loop_runs_while_a_request_waits():
    async def main() -> int:
        beats = 0
        stop = asyncio.Event()

        async def heartbeat() -> None:
            nonlocal beats
            while not stop.is_set():
                beats += 1
                await asyncio.sleep(0.005)

        async with rmd_rt.AsyncBus.simulated([1], timeout_s=0.2, retries=0) as bus:
            task = asyncio.create_task(heartbeat())
            with pytest.raises(rmd_rt.NoReplyError):
                await bus.read_status_1(7)
            stop.set()
            await task
        return beats

    beats = asyncio.run(main())
    # About 40 beats of 5 ms in the 0.2 s wait; an event loop blocked by the request: 1.
    assert beats >= 5, beats


def test_async_commands_move_motors_and_refuse_rom_writes():
    async def main() -> None:
        async with rmd_rt.AsyncBus.simulated([1], virtual_time=True) as bus:
            reply = await bus.torque(1, amps=0.8)
            assert reply["command"] == "torque"
            sim = bus.simulator()
            assert sim is not None and sim.motors()[0]["energising"]
            with pytest.raises(rmd_rt.RomWriteNotConfirmed):
                await bus.write_zero_rom(1)
            await bus.motor_off(1)
            assert sim.motors()[0]["safe"]

    asyncio.run(main())
