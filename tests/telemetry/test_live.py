"""The live server, through an independent WebSocket client (`websockets`) speaking the Foxglove
WebSocket protocol: advertise, subscribe, binary message data; messages decoded with
mcap-ros2-support's CDR decoder and the standard JSON parser."""

import asyncio
import json
import struct
import subprocess
import time

import websockets

from conftest import check_joint_state, load_truth, ros2_decoder, stamp_ns, synth_args

# The SDK's name for the protocol (identical to the former "foxglove.websocket.v1").
SUBPROTOCOL = "foxglove.sdk.v1"
LIVE_RATE_HZ = 50
OP_MESSAGE_DATA = 0x01


def start_server(tmp_path):
    truth = tmp_path / "truth.json"
    args = synth_args(
        "--ticks", 6000, "--realtime", "--foxglove", "127.0.0.1:0", "--live-rate", LIVE_RATE_HZ,
        truth=truth,
    )
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = process.stdout.readline().strip()
    assert line.startswith("foxglove ws://"), (line, process.stderr.read() if process.poll() else "")
    return process, line.removeprefix("foxglove "), truth


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


def test_a_websocket_client_receives_decoded_messages_from_subscribed_channels(tmp_path):
    process, url, truth_path = start_server(tmp_path)
    try:
        wanted = ["/joint_states", "/motor_states", "/diagnostics"]
        received = asyncio.run(
            collect(
                url,
                wanted,
                lambda r: len(r["/joint_states"]) >= 60
                and len(r["/motor_states"]) >= 10
                and len(r["/diagnostics"]) >= 1,
            )
        )
    finally:
        process.terminate()
        out, err = process.communicate(timeout=30)
    assert process.returncode == 0, err

    truth = load_truth(truth_path)
    states = received["/joint_states"]
    channel = states[0][2]
    assert (channel["encoding"], channel["schemaEncoding"], channel["schemaName"]) == (
        "cdr",
        "ros2msg",
        "sensor_msgs/msg/JointState",
    )
    decode = ros2_decoder(channel["schemaName"], channel["schema"])
    stamps = []
    for log_time, payload, _ in states:
        msg = decode(payload)
        stamp = stamp_ns(msg.header)
        assert stamp == log_time
        tick = (stamp - truth["start_unix_ns"]) // 1_000_000
        check_joint_state(msg, truth, tick)
        stamps.append(stamp)
    assert stamps == sorted(stamps)
    # Decimated: no more than the live rate (the 1 kHz records would give 20 times as many).
    span_s = (stamps[-1] - stamps[0]) / 1e9
    assert len(stamps) - 1 <= span_s * LIVE_RATE_HZ + 1, (len(stamps), span_s)

    for _, payload, channel in received["/motor_states"]:
        assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
        assert list(json.loads(payload)) == truth["joints"]

    diag = received["/diagnostics"][0]
    decode = ros2_decoder(diag[2]["schemaName"], diag[2]["schema"])
    statuses = decode(diag[1]).status
    assert [s.name for s in statuses][0] == "rmd_rt: loop"
    assert len(statuses) == 1 + len(truth["joints"])

    stats = json.loads(out.strip().splitlines()[-1])
    (live,) = stats["sinks"]
    assert live["name"].startswith("foxglove ws://127.0.0.1:")
    assert live["errors"] == 0
