"""encode / decode against the `rmd` tool itself: the same frames, the same JSON, the same
messages."""

from __future__ import annotations

import json
from typing import Any, Dict, List, Tuple

import pytest

import rmd_rt
from conftest import run_rmd

# (rmd encode arguments, the same command for rmd_rt.encode): every command of the protocol,
# raw and physical values, both dialects.
ENCODE_CASES: List[Tuple[str, Tuple[str, Dict[str, Any]]]] = [
    ("read-pid --id 1", ("read-pid", {"id": 1})),
    ("read-accel --id 4", ("read-accel", {"id": 4})),
    ("write-accel-ram --id 1 --accel 10000", ("write-accel-ram", {"id": 1, "accel": 10000})),
    ("write-accel-ram --id 2 --accel=-5", ("write-accel-ram", {"id": 2, "accel": -5})),
    ("read-encoder --id 1", ("read-encoder", {"id": 1})),
    (
        "write-encoder-offset --id 1 --encoder-offset 4660",
        ("write-encoder-offset", {"id": 1, "encoder_offset": 4660}),
    ),
    (
        "write-encoder-offset --id 3 --encoder-offset 60000 --encoder-bits 18",
        ("write-encoder-offset", {"id": 3, "encoder_offset": 60000, "encoder_bits": 18}),
    ),
    ("write-zero-rom --id 1", ("write-zero-rom", {"id": 1})),
    ("read-multi-turn-angle --id 1", ("read-multi-turn-angle", {"id": 1})),
    ("read-single-turn-angle --id 7", ("read-single-turn-angle", {"id": 7})),
    ("read-status-1 --id 1", ("read-status-1", {"id": 1})),
    ("clear-error --id 1", ("clear-error", {"id": 1})),
    ("read-status-2 --id 1", ("read-status-2", {"id": 1})),
    ("read-status-3 --id 1", ("read-status-3", {"id": 1})),
    ("motor-off --id 1", ("motor-off", {"id": 1})),
    ("motor-stop --id 1", ("motor-stop", {"id": 1})),
    ("motor-run --id 32", ("motor-run", {"id": 32})),
    ("torque --id 32 --iq-control -100", ("torque", {"id": 32, "iq_control": -100})),
    ("torque --id 1 --amps 1.6", ("torque", {"id": 1, "amps": 1.6})),
    ("speed --id 1 --speed-control 36000", ("speed", {"id": 1, "speed_control": 36000})),
    ("speed --id 1 --dps -0.01", ("speed", {"id": 1, "dps": -0.01})),
    ("position-1 --id 1 --angle-control -9000", ("position-1", {"id": 1, "angle_control": -9000})),
    ("position-1 --id 1 --deg -90", ("position-1", {"id": 1, "deg": -90.0})),
    (
        "position-2 --id 1 --max-speed 500 --angle-control 18000",
        ("position-2", {"id": 1, "max_speed": 500, "angle_control": 18000}),
    ),
    (
        "position-3 --id 1 --spin-direction ccw --angle-control 35999",
        ("position-3", {"id": 1, "spin_direction": "ccw", "angle_control": 35999}),
    ),
    (
        "position-4 --id 1 --spin-direction cw --max-speed 360 --deg 90",
        ("position-4", {"id": 1, "spin_direction": "cw", "max_speed": 360, "deg": 90.0}),
    ),
    (
        "multi-torque --iq-control 100,-100,0,2000",
        ("multi-torque", {"iq_control": [100, -100, 0, 2000]}),
    ),
    (
        "multi-torque --amps -32,0.016,-0.016,8",
        ("multi-torque", {"amps": [-32.0, 0.016, -0.016, 8.0]}),
    ),
    (
        "write-pid-ram --id 2 --angle-pid-kp 100 --angle-pid-ki 50 --speed-pid-kp 40 "
        "--speed-pid-ki 30 --iq-pid-kp 20 --iq-pid-ki 10",
        (
            "write-pid-ram",
            {
                "id": 2,
                "angle_pid_kp": 100,
                "angle_pid_ki": 50,
                "speed_pid_kp": 40,
                "speed_pid_ki": 30,
                "iq_pid_kp": 20,
                "iq_pid_ki": 10,
            },
        ),
    ),
    (
        "write-pid-rom --id 3 --angle-pid-kp 1 --angle-pid-ki 2 --speed-pid-kp 3 "
        "--speed-pid-ki 4 --iq-pid-kp 5 --iq-pid-ki 255",
        (
            "write-pid-rom",
            {
                "id": 3,
                "angle_pid_kp": 1,
                "angle_pid_ki": 2,
                "speed_pid_kp": 3,
                "speed_pid_ki": 4,
                "iq_pid_kp": 5,
                "iq_pid_ki": 255,
            },
        ),
    ),
    (
        "torque --id 1 --amps 10 --protocol lk-v2.3x --lk-series mf",
        ("torque", {"id": 1, "amps": 10.0, "protocol": "lk-v2.3x", "lk_series": "mf"}),
    ),
    (
        "multi-torque --iq-control 2048,-2048,1,0 --protocol lk-v2.3x --lk-series mg",
        (
            "multi-torque",
            {"iq_control": [2048, -2048, 1, 0], "protocol": "lk-v2.3x", "lk_series": "mg"},
        ),
    ),
]


def cli_encode(rmd_bin, args: str) -> str:
    out = run_rmd(rmd_bin, ["encode", *args.split()])
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@pytest.mark.parametrize("args,call", ENCODE_CASES, ids=[c[0] for c in ENCODE_CASES])
def test_encode_equals_rmd_encode(rmd_bin, args, call):
    command, fields = call
    assert rmd_rt.encode(command, **fields) == cli_encode(rmd_bin, args)


def test_every_command_is_covered():
    # The table above names every command encode knows; a new one must join the parity test.
    covered = {call[0] for _, call in ENCODE_CASES}
    with pytest.raises(rmd_rt.ProtocolError) as error:
        rmd_rt.encode("no-such-command", id=1)
    listed = str(error.value).split("expected one of ", 1)[1].split(", ")
    assert covered == set(listed)


# Values out of range: the Python message is the one `rmd encode` prints (after "error: ").
ENCODE_ERRORS = [
    ("torque --id 1 --iq-control 2001", ("torque", {"id": 1, "iq_control": 2001})),
    ("torque --id 1 --amps 32.5", ("torque", {"id": 1, "amps": 32.5})),
    ("torque --id 1 --amps nan", ("torque", {"id": 1, "amps": float("nan")})),
    ("torque --id 33 --iq-control 5", ("torque", {"id": 33, "iq_control": 5})),
    ("torque --id 0 --iq-control 5", ("torque", {"id": 0, "iq_control": 5})),
    (
        "position-3 --id 1 --spin-direction ccw --angle-control 36000",
        ("position-3", {"id": 1, "spin_direction": "ccw", "angle_control": 36000}),
    ),
    (
        "position-2 --id 1 --max-speed 70000 --angle-control 0",
        ("position-2", {"id": 1, "max_speed": 70000, "angle_control": 0}),
    ),
    (
        "write-encoder-offset --id 1 --encoder-offset 16384",
        ("write-encoder-offset", {"id": 1, "encoder_offset": 16384}),
    ),
    (
        "write-encoder-offset --id 1 --encoder-offset 4096 --encoder-bits 12",
        ("write-encoder-offset", {"id": 1, "encoder_offset": 4096, "encoder_bits": 12}),
    ),
    (
        "torque --id 1 --amps 20 --protocol lk-v2.3x --lk-series mf",
        ("torque", {"id": 1, "amps": 20.0, "protocol": "lk-v2.3x", "lk_series": "mf"}),
    ),
    (
        "multi-torque --iq-control 0,0,0,2100",
        ("multi-torque", {"iq_control": [0, 0, 0, 2100]}),
    ),
    ("speed --id 1 --dps 1e12", ("speed", {"id": 1, "dps": 1e12})),
]


@pytest.mark.parametrize("args,call", ENCODE_ERRORS, ids=[c[0] for c in ENCODE_ERRORS])
def test_encode_errors_carry_rmd_encodes_message(rmd_bin, args, call):
    command, fields = call
    out = run_rmd(rmd_bin, ["encode", *args.split()])
    assert out.returncode != 0 and out.stdout == ""
    with pytest.raises(rmd_rt.ProtocolError) as error:
        rmd_rt.encode(command, **fields)
    message = str(error.value)
    assert message, "an empty message"
    assert message in out.stderr, f"python: {message!r}\ncli: {out.stderr!r}"


def test_encode_refuses_what_the_command_does_not_take():
    with pytest.raises(rmd_rt.ProtocolError, match="takes no field `max_speed`"):
        rmd_rt.encode("position-1", id=1, deg=10.0, max_speed=3)
    with pytest.raises(rmd_rt.ProtocolError, match="give iq_control or amps, not both"):
        rmd_rt.encode("torque", id=1, iq_control=1, amps=1.0)
    with pytest.raises(rmd_rt.ProtocolError, match="needs id"):
        rmd_rt.encode("read-status-1")
    with pytest.raises(rmd_rt.ProtocolError, match="give no id"):
        rmd_rt.encode("multi-torque", id=1, amps=[0, 0, 0, 0])
    with pytest.raises(rmd_rt.ProtocolError, match="expected 4 values"):
        rmd_rt.encode("multi-torque", amps=[0, 0, 0])
    with pytest.raises(rmd_rt.ProtocolError, match="must be an integer"):
        rmd_rt.encode("torque", id=1, iq_control=1.5)
    with pytest.raises(rmd_rt.ProtocolError, match="needs the motors' series"):
        rmd_rt.encode("read-status-1", id=1, protocol="lk-v2.3x")


# (line, --as): requests of every kind, replies (v1.61 and LK-TECH), fields out of range,
# candump's log form with a timestamp and an interface.
DECODE_CASES = [
    ("141#A100000064000000", "request", []),
    ("280#64009CFF0000D007", "request", []),
    ("142#31006432281E140A", "request", []),
    ("141#A600680128230000", "request", []),
    ("141#A50100009F8C0000", "request", []),
    ("141#9100000000003412", "request", []),
    ("141#3400000010270000", "request", []),
    ("141#A2000000A08C0000", "request", []),
    ("141#9A00000000000000", "request", []),
    ("141#9A1E00E0010000 00", "reply", []),
    ("141#9A1E0000E0010001", "reply", []),
    ("141#9C1E00640A000010", "reply", []),
    ("141#9C1E0009F6FF0010", "reply", []),
    ("141#9D00640032009CFF", "reply", []),
    ("141#9000341200200010", "reply", []),
    ("141#3000646432281E14", "reply", []),
    ("141#920010270000000000", "reply", []),
    ("141#9200102700000000", "reply", []),
    ("141#94000000000000A08C", "reply", []),
    ("141#94000000000010 27", "reply", []),
    ("141#9400000000001027", "reply", []),
    ("141#9400000000000A08C", "reply", []),
    ("141#8000000000000000", "reply", []),
    ("(1700000000.250000) can0 141#9C1E00640A000010", "reply", []),
    ("141#9A1E2C0164000100", "reply", ["--protocol", "lk-v2.3x", "--lk-series", "mg"]),
    ("141#A1190008E8030010", "reply", ["--protocol", "lk-v2.3x", "--lk-series", "mf"]),
    ("141#9000FFFFFFFF0000", "reply", ["--encoder-bits", "12"]),
]


def py_decode(line: str, direction: str, extra: List[str]) -> Dict[str, Any]:
    options: Dict[str, Any] = {}
    it = iter(extra)
    for flag in it:
        value = next(it)
        key = flag.lstrip("-").replace("-", "_")
        options[key] = int(value) if key == "encoder_bits" else value
    return rmd_rt.decode(line, direction=direction, **options)


@pytest.mark.parametrize("line,direction,extra", DECODE_CASES, ids=[c[0] for c in DECODE_CASES])
def test_decode_equals_rmd_decode(rmd_bin, line, direction, extra):
    out = run_rmd(rmd_bin, ["decode", "--as", direction, *extra], stdin=line + "\n")
    objects = [json.loads(text) for text in out.stdout.splitlines()]
    if not objects:
        # The CLI could not read the frame: Python raises with the same message.
        assert out.returncode == 1
        with pytest.raises(rmd_rt.ProtocolError) as error:
            py_decode(line, direction, extra)
        assert f"line 1: {error.value}" in out.stderr
        return
    (cli,) = objects
    py = py_decode(line, direction, extra)
    assert py == cli
    assert list(py) == list(cli), "the same keys in the same order"
    # A field out of range is in `errors` in both, and is what the CLI reported on stderr.
    for error in py.get("errors", []):
        assert f"line 1: {error['error']}" in out.stderr


def test_decode_auto_reads_a_lone_line_as_rmd_decode_does(rmd_bin):
    line = "141#9C00000000000000"
    out = run_rmd(rmd_bin, ["decode"], stdin=line + "\n")
    assert rmd_rt.decode(line) == json.loads(out.stdout)


def test_decode_refuses_bad_arguments():
    with pytest.raises(rmd_rt.ProtocolError, match="unknown direction"):
        rmd_rt.decode("141#9C00000000000000", direction="sideways")
    with pytest.raises(rmd_rt.ProtocolError, match="out of range 12..=18"):
        rmd_rt.decode("141#9C00000000000000", encoder_bits=40)
    with pytest.raises(rmd_rt.ProtocolError):
        rmd_rt.decode("not a frame")


def test_the_guides_reply_example_decodes_in_range():
    # docs/python.md's example of a read-status-2 reply (little-endian fields: iq 100 is 64 00).
    reply = rmd_rt.decode("(1700000000.25) can0 141#9C1E64000A000010", direction="reply")
    assert "errors" not in reply, reply
    assert (reply["command"], reply["iq"], reply["speed_dps"], reply["encoder"]) == (
        "read-status-2", 100, 10.0, 4096,
    )
    assert reply["iq_amps"] == pytest.approx(100 * 33 / 2048)
