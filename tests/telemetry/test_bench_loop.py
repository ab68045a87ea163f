"""`rmd bench loop` with telemetry sinks, read back by independent implementations: the MCAP file
with the `mcap` reader (CDR decoded by mcap-ros2-support), the CSV with Python's csv module, the
live server with a `websockets` client speaking the Foxglove WebSocket protocol.

The values are checked against the run itself: the benchmark's controller tracks known sine
targets and reports its RMS and largest tracking error; the same errors recomputed from the
MCAP's joint positions must agree with them exactly (to rounding)."""

import asyncio
import csv
import json
import math
import signal
import subprocess
import time

import pytest
import websockets
from mcap.reader import make_reader

from conftest import (
    SUBPROTOCOL,
    collect,
    decoder_factories,
    free_port,
    rmd_path,
    ros2_decoder,
    run_rmd,
    stamp_ns,
)

# The benchmark's targets (crates/rmd-cli/src/cmd/bench/pd.rs): joint i follows
# AMPLITUDE * sin(2 pi F t + i pi / 2) degrees; its errors are measured from SETTLE_S on.
AMPLITUDE_DEG = 20.0
FREQUENCY_HZ = 0.5
SETTLE_S = 0.5
JOINTS = ["bus0_motor1", "bus0_motor2", "bus0_motor3", "bus0_motor4"]


def target_deg(i: int, t: float) -> float:
    return AMPLITUDE_DEG * math.sin(2 * math.pi * FREQUENCY_HZ * t + i * math.pi / 2)


def test_virtual_time_mcap_has_one_joint_state_per_tick_with_the_run_values(tmp_path):
    mcap_path, csv_path = tmp_path / "run.mcap", tmp_path / "run.csv"
    done = run_rmd(
        "bench", "loop", "--virtual-time", "--seconds", "3", "--mcap", mcap_path, "--csv",
        csv_path, "--json",
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    ticks = report["ticks"]
    assert ticks == 3000
    assert report["telemetry_drops"] == 0
    sinks = {s["name"].split()[0]: s for s in report["telemetry"]}
    assert set(sinks) == {"mcap", "csv"}
    for sink in sinks.values():
        assert (sink["written"], sink["dropped"], sink["errors"]) == (ticks, 0, 0), sink

    with open(mcap_path, "rb") as f:
        reader = make_reader(f, decoder_factories=decoder_factories())
        summary = reader.get_summary()
        assert summary is not None, "the file was closed with its summary"
        states, timing = [], []
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            if channel.topic == "/joint_states":
                assert schema.name == "sensor_msgs/msg/JointState"
                assert stamp_ns(decoded.header) == message.log_time
                states.append(decoded)
            elif channel.topic == "/loop_timing":
                timing.append(decoded)
    # Stable for scripts: one /joint_states message per tick, none lost on virtual time.
    assert len(states) == ticks
    assert [t["tick"] for t in timing] == list(range(ticks))
    start = stamp_ns(states[0].header)
    squared, count, largest = 0.0, 0, 0.0
    for k, msg in enumerate(states):
        assert list(msg.name) == JOINTS
        assert stamp_ns(msg.header) - start == k * 1_000_000, k
        t = k * 1_000_000 / 1e9
        assert timing[k]["time_s"] == t
        for i, rad in enumerate(msg.position):
            assert math.isfinite(rad) and math.isfinite(msg.velocity[i]) and math.isfinite(msg.effort[i])
            if t >= SETTLE_S:
                error = target_deg(i, t) - math.degrees(rad)
                squared += error * error
                count += 1
                largest = max(largest, abs(error))
    bench = report["bench"]
    assert math.isclose(math.sqrt(squared / count), bench["tracking_rms_error_deg"], rel_tol=1e-9)
    assert math.isclose(largest, bench["tracking_max_error_deg"], rel_tol=1e-9)
    # The joints moved through the sine: nobody wrote zeros.
    assert largest < 0.5 * AMPLITUDE_DEG
    assert max(abs(m.position[0]) for m in states) > math.radians(0.9 * AMPLITUDE_DEG)

    # The CSV sink got the same ticks and the same positions.
    with open(csv_path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == ticks
    for k in range(0, ticks, 97):
        assert int(rows[k]["tick"]) == k
        for i, name in enumerate(JOINTS):
            assert math.isclose(float(rows[k][f"{name}.position_rad"]), states[k].position[i], rel_tol=1e-12, abs_tol=1e-12)


def start_live(port, *extra):
    """`rmd bench loop` serving live on loopback `port`, on virtual time for far longer than a
    test waits: the test ends it with a signal. (In real time, simulated motors on threads of
    their own miss replies when a loaded machine does not run them, and the loop rightly stops
    on the fault: not what these tests are about.)"""
    return subprocess.Popen(
        [
            rmd_path(), "bench", "loop", "--virtual-time", "--seconds", "3000",
            "--foxglove", f"127.0.0.1:{port}", "--json", *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def collect_when_up(process, url, wanted, enough):
    """Collects from the live server once it listens (retrying until it does)."""
    deadline = time.monotonic() + 60
    while True:
        try:
            return asyncio.run(collect(url, wanted, enough))
        except OSError:
            # Not listening yet.
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, "the live server never came up"
            time.sleep(0.1)


def stop(process):
    """Ends the run with SIGINT (the signal policy: report and files still written)."""
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    return json.loads(out), err


def test_live_server_serves_the_channels_while_the_loop_runs(tmp_path):
    port = free_port()
    process = start_live(port)
    try:
        received = collect_when_up(
            process,
            f"ws://127.0.0.1:{port}",
            ["/joint_states", "/loop_timing"],
            lambda r: len(r["/joint_states"]) >= 50 and len(r["/loop_timing"]) >= 10,
        )
        report, err = stop(process)
    finally:
        if process.poll() is None:
            process.kill()

    states = received["/joint_states"]
    channel = states[0][2]
    assert (channel["encoding"], channel["schemaName"]) == ("cdr", "sensor_msgs/msg/JointState")
    decode = ros2_decoder(channel["schemaName"], channel["schema"])
    stamps = []
    for log_time, payload, _ in states:
        msg = decode(payload)
        assert stamp_ns(msg.header) == log_time
        assert list(msg.name) == JOINTS
        assert all(math.isfinite(p) and abs(math.degrees(p)) < 2 * AMPLITUDE_DEG for p in msg.position)
        stamps.append(log_time)
    assert stamps == sorted(stamps)
    # Decimated to the default 100 Hz (of run time) from the 1 kHz loop.
    span_s = (stamps[-1] - stamps[0]) / 1e9
    assert len(stamps) - 1 <= span_s * 100 + 1, (len(stamps), span_s)
    for _, payload, _ in received["/loop_timing"]:
        timing = json.loads(payload)
        assert timing["tick"] >= 0 and timing["wake_latency_us"] >= 0

    assert report["stop_reason"] == "stop requested"
    (live,) = report["telemetry"]
    assert live["name"] == f"foxglove ws://127.0.0.1:{port}"
    assert live["errors"] == 0 and live["written"] > 0
    assert live["note"].startswith("1 client(s) served, 0 refused"), live["note"]


def test_a_client_over_the_limit_is_refused_and_counted_while_the_others_are_served():
    port = free_port()
    process = start_live(port, "--foxglove-clients", "1")
    url = f"ws://127.0.0.1:{port}"

    async def two_clients():
        async with websockets.connect(url, subprotocols=[SUBPROTOCOL]) as first:
            # The first is served: it receives the server's info.
            info = json.loads(await asyncio.wait_for(first.recv(), 30))
            assert info["op"] == "serverInfo"
            with pytest.raises(websockets.exceptions.InvalidStatus) as refused:
                async with websockets.connect(url, subprotocols=[SUBPROTOCOL]):
                    pass
            assert refused.value.response.status_code == 503
            assert b"the limit" in refused.value.response.body
            # Still served.
            assert await asyncio.wait_for(first.recv(), 30)

    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                asyncio.run(two_clients())
                break
            except OSError:
                assert process.poll() is None, process.communicate()
                assert time.monotonic() < deadline, "the live server never came up"
                time.sleep(0.1)
        report, _ = stop(process)
    finally:
        if process.poll() is None:
            process.kill()
    (live,) = report["telemetry"]
    assert live["note"].startswith("1 client(s) served, 1 refused over the limit of 1"), live


def test_a_server_open_to_the_network_says_so_when_it_starts():
    # In a network namespace of its own (only its loopback): 0.0.0.0 reaches no real network.
    done = subprocess.run(
        [
            "unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh",
            rmd_path(), "bench", "loop", "--virtual-time", "--seconds", "0.2",
            "--foxglove", "0.0.0.0:0", "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "warning: the live telemetry server listens on 0.0.0.0:" in done.stderr, done.stderr
    assert "without authentication or encryption" in done.stderr
    # On loopback: no warning.
    done = run_rmd("bench", "loop", "--virtual-time", "--seconds", "0.2", "--foxglove", "127.0.0.1:0")
    assert done.returncode == 0, done.stderr
    assert "warning" not in done.stderr, done.stderr
