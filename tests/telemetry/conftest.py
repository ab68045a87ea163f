"""Shared helpers of the telemetry tests: run the synthetic writer, read its truth, decode MCAP.

Everything here is independent of rmd-telemetry's Rust code except the writer it runs: MCAP is
read by the `mcap` package, CDR decoded by `mcap-ros2-support`, JSON by the standard library and
checked by `jsonschema`.
"""

import asyncio
import json
import math
import os
import struct
import subprocess
import time
from pathlib import Path

import websockets

import pytest
from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory as Ros2DecoderFactory

# The SDK's name for the Foxglove WebSocket protocol (identical to the former
# "foxglove.websocket.v1").
SUBPROTOCOL = "foxglove.sdk.v1"
OP_MESSAGE_DATA = 0x01

# A fixed start (2023-11-14T22:13:20Z) so that stamps are predictable.
START_UNIX_NS = 1_700_000_000_000_000_000


def built(variable: str) -> str:
    """The path of a program run.sh built, from its environment variable."""
    path = os.environ.get(variable)
    if not path:
        pytest.fail(f"{variable} is not set: run the tests through tests/telemetry/run.sh")
    return path


def synth_path() -> str:
    return built("TELEMETRY_SYNTH")


def rmd_path() -> str:
    return built("RMD_BIN")


def pd_hold_path() -> str:
    """The `pd_hold` example."""
    return built("PD_HOLD_BIN")


def run_rmd(*args, timeout: float = 300):
    """Runs `rmd ARGS...` to completion; returns the completed process (text output)."""
    return subprocess.run(
        [rmd_path(), *[str(a) for a in args]],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def free_port() -> int:
    """A TCP port on loopback that nothing listens on now."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def synth_args(*args, truth: Path, start_unix_ns: int = START_UNIX_NS):
    return [
        synth_path(),
        "--truth",
        str(truth),
        "--start-unix-ns",
        str(start_unix_ns),
        *[str(a) for a in args],
    ]


def run_synth(*args, truth: Path, timeout: float = 120):
    """Runs the writer to completion; returns its final statistics (the last stdout line)."""
    done = subprocess.run(
        synth_args(*args, truth=truth),
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, f"telemetry_synth failed:\n{done.stdout}\n{done.stderr}"
    return json.loads(done.stdout.strip().splitlines()[-1])


def load_truth(path: Path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


class JsonDecoderFactory(McapDecoderFactory):
    """Decodes `json` messages with the standard library."""

    def decoder_for(self, message_encoding, schema):
        if message_encoding != "json":
            return None
        return lambda data: json.loads(data)


def decoder_factories():
    return [Ros2DecoderFactory(), JsonDecoderFactory()]


def ros2_decoder(schema_name: str, schema_text: str):
    """A CDR decoder for a ros2msg schema, as mcap-ros2-support builds it (no MCAP file needed)."""
    schema = Schema(id=1, name=schema_name, encoding="ros2msg", data=schema_text.encode())
    decoder = Ros2DecoderFactory().decoder_for("cdr", schema)
    assert decoder is not None
    return decoder


def stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def same(value, expected) -> bool:
    """Exact equality, with NaN (or None) standing for "no value"."""
    if expected is None:
        return value is None or (isinstance(value, float) and math.isnan(value))
    return value == expected


def check_joint_state(msg, truth, tick: int):
    """A decoded JointState against the truth of `tick`: names, positions, velocities, efforts."""
    rec = truth["records"][tick]
    assert rec["tick"] == tick
    assert list(msg.name) == truth["joints"]
    assert stamp_ns(msg.header) == truth["start_unix_ns"] + rec["since_start_ns"]
    for j, replied in enumerate(rec["replied"]):
        pos = rec["position"][j] if replied else None
        vel = rec["velocity"][j] if replied else None
        assert same(msg.position[j], pos), (tick, j, msg.position[j], pos)
        assert same(msg.velocity[j], vel), (tick, j, msg.velocity[j], vel)
        # Effort: the joint torque where the torque constant is known, NaN where it is not.
        eff = rec["effort"][j] if replied and truth["torque_known"][j] else None
        assert same(msg.effort[j], eff), (tick, j, msg.effort[j], eff)


async def collect(url, wanted, enough, timeout=30.0):
    """Connects, subscribes to the `wanted` topics, and collects decoded-ready payloads per topic
    until `enough(received)` holds."""
    async with websockets.connect(url, subprotocols=[SUBPROTOCOL], max_size=None) as ws:
        assert ws.subprotocol == SUBPROTOCOL
        channels, subscriptions, received = {}, {}, {topic: [] for topic in wanted}
        deadline = time.monotonic() + timeout
        while not enough(received):
            remaining = deadline - time.monotonic()
            assert remaining > 0, f"timed out: {({t: len(v) for t, v in received.items()})}"
            frame = await asyncio.wait_for(ws.recv(), remaining)
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    new = []
                    for channel in message["channels"]:
                        if channel["topic"] in wanted and channel["topic"] not in channels.values():
                            channels[channel["id"]] = channel
                            new.append(channel)
                    if new:
                        subs = []
                        for channel in new:
                            sub_id = len(subscriptions) + 1
                            subscriptions[sub_id] = channel
                            subs.append({"id": sub_id, "channelId": channel["id"]})
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                continue
            assert frame[0] == OP_MESSAGE_DATA, f"unexpected binary opcode {frame[0]}"
            sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
            channel = subscriptions[sub_id]
            received[channel["topic"]].append((log_time, bytes(frame[13:]), channel))
        return received
