"""`rmd decode LOG --mcap OUT` and `rmd torque --mcap OUT`: candump logs of RMD traffic as MCAP
files of decoded values per motor, read back with the Python `mcap` reader and checked against
the frames' bytes decoded here, independently, from the v1.61 spec's layouts."""

import json
import struct

import jsonschema
from mcap.reader import make_reader

from conftest import run_rmd

IQ_AMPS_PER_LSB = 33 / 2048  # v1.61: iq -2048..2048 for -33..33 A


def parse_log(path):
    """(log time ns, interface, can id, data bytes, direction marker) per line of a -L log."""
    frames = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            stamp, interface, frame, marker = line.split()
            seconds, micros = stamp.strip("()").split(".")
            can_id, data = frame.split("#")
            frames.append(
                (int(seconds) * 1_000_000_000 + int(micros) * 1000, interface, int(can_id, 16),
                 bytes.fromhex(data), marker)
            )
    return frames


def expected_reply(data: bytes):
    """The values of a reply, decoded from its bytes (the spec's layouts)."""
    code = data[0]
    if code in (0x9C, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6):  # status 2 and the control replies
        temperature, iq, speed, encoder = struct.unpack("<bhhH", data[1:8])
        return {"temperature_celsius": float(temperature), "iq": iq,
                "iq_amps": iq * IQ_AMPS_PER_LSB, "speed_dps": float(speed), "encoder": encoder}
    if code == 0x9A:  # status 1
        temperature = struct.unpack("<b", data[1:2])[0]
        (voltage,) = struct.unpack("<H", data[3:5])
        return {"temperature_celsius": float(temperature), "voltage_volts": voltage / 10,
                "error_state": data[7]}
    if code == 0x92:  # multi-turn angle, 0.01 degree per LSB, int56 little-endian
        angle = int.from_bytes(data[1:8], "little", signed=True)
        return {"motor_angle_degrees": angle / 100}
    if code in (0x80, 0x81, 0x88):  # motor off, stop, run: the request echoed, no values
        return {}
    return None


def read_mcap(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None, "closed with a summary"
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        messages = [(channel, schema, message) for schema, channel, message in reader.iter_messages()]
    return summary, metadata, messages


def check_against_log(log, mcap, time_tolerance_ns=0):
    frames = parse_log(log)
    summary, metadata, messages = read_mcap(mcap)
    assert metadata["rmd_rt.decode"]["protocol"] == "v1.61"
    # Every frame of the log is one message, in order, on its motor's channel.
    assert len(messages) == len(frames)
    replies = 0
    for (log_ns, interface, can_id, data, marker), (channel, schema, message) in zip(frames, messages):
        value = json.loads(message.data)
        jsonschema.validate(value, json.loads(schema.data))
        assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
        assert abs(message.log_time - log_ns) <= time_tolerance_ns, (message.log_time, log_ns)
        motor = can_id - 0x140
        side = "replies" if marker == "R" else "requests"
        assert channel.topic == f"/{interface}/motor{motor}/{side}"
        assert value["id"] == motor and value["interface"] == interface
        assert value["direction"] == ("reply" if marker == "R" else "request")
        if marker == "R":
            replies += 1
            expected = expected_reply(data)
            assert expected is not None, f"a reply this test does not know: {data.hex()}"
            for key, want in expected.items():
                assert value[key] == want or abs(value[key] - want) < 1e-9, (key, value, want)
    assert replies > 0
    counts = summary.statistics.channel_message_counts
    assert sum(counts.values()) == len(frames)
    return messages


def test_a_log_of_torque_and_status_reads_becomes_decoded_values_per_motor(tmp_path):
    torque_log, monitor_log = tmp_path / "torque.log", tmp_path / "monitor.log"
    done = run_rmd("torque", "2", "--amps", "0.8", "--sim", "--duration", "0.4s", "--log", torque_log)
    assert done.returncode == 0, done.stderr
    done = run_rmd("monitor", "--sim", "--ids", "1,3", "--count", "3", "--json", "--log", monitor_log)
    assert done.returncode == 0, done.stderr
    log = tmp_path / "both.log"
    log.write_text(torque_log.read_text() + monitor_log.read_text())

    out = tmp_path / "decoded.mcap"
    done = run_rmd("decode", log, "--mcap", out)
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""
    messages = check_against_log(log, out)
    topics = {channel.topic for channel, _, _ in messages}
    assert topics == {f"/sim/motor{m}/{side}" for m in (1, 2, 3) for side in ("requests", "replies")}
    # The torque drive's replies carry a moving motor: the current and speed are not zero.
    replies = [json.loads(m.data) for c, _, m in messages if c.topic == "/sim/motor2/replies"]
    currents = [r["iq_amps"] for r in replies if "iq_amps" in r]
    assert max(currents) > 0.5
    # The same objects `rmd decode` prints as JSON lines.
    lines = [json.loads(l) for l in run_rmd("decode", log).stdout.splitlines()]
    assert [json.loads(m.data) for _, _, m in messages] == lines


def test_bad_lines_are_reported_and_the_rest_still_written(tmp_path):
    log = tmp_path / "bad.log"
    log.write_text(
        "(1700000000.000100) can0 141#9C00000000000000 T\n"
        "(1700000000.000200) can0 7FF#0011\n"
        "(1700000000.000300) can0 141#9C1A0C0032001027 R\n"
    )
    out = tmp_path / "bad.mcap"
    done = run_rmd("decode", log, "--mcap", out)
    assert done.returncode == 1
    assert "line 2:" in done.stderr
    _, _, messages = read_mcap(out)
    assert [m.log_time for _, _, m in messages] == [1_700_000_000_000_100_000, 1_700_000_000_000_300_000]
    reply = json.loads(messages[1][2].data)
    assert (reply["temperature_celsius"], reply["iq"], reply["speed_dps"], reply["encoder"]) == (26.0, 12, 50.0, 10000)


def test_torque_records_its_frames_decoded(tmp_path):
    out = tmp_path / "torque.mcap"
    log = tmp_path / "torque.log"
    done = run_rmd("torque", "1", "--amps", "-0.6", "--sim", "--duration", "0.3s", "--mcap", out, "--log", log)
    assert done.returncode == 0, done.stderr
    assert f"mcap {out}:" in done.stderr
    # The --log and --mcap recorders stamp each frame with their own clock reading.
    check_against_log(log, out, time_tolerance_ns=1_000_000)
    done = run_rmd("speed", "1", "--dps", "90", "--sim", "--foxglove")
    assert done.returncode == 2
    assert "does not run the real-time loop" in done.stderr
