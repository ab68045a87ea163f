"""The MCAP file, read with the independent Python readers: every message decodes, one
/joint_states message per record, values and times as written, summary and index present."""

import json
import math
from collections import Counter, defaultdict

import jsonschema
import pytest
from mcap.reader import make_reader

from conftest import (
    check_joint_state,
    decoder_factories,
    load_truth,
    run_synth,
    same,
    stamp_ns,
)

TICKS = 3500  # 3.5 s at 1 kHz: four /diagnostics messages (three full seconds and the rest)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mcap")
    mcap, csv, truth = tmp / "run.mcap", tmp / "run.csv", tmp / "truth.json"
    layout = tmp / "layout.json"
    stats = run_synth(
        "--ticks", TICKS, "--mcap", mcap, "--csv", csv, "--foxglove-layout", layout, truth=truth
    )
    with open(mcap, "rb") as f:
        reader = make_reader(f, decoder_factories=decoder_factories())
        summary = reader.get_summary()
        header = reader.get_header()
        metadata = list(reader.iter_metadata())
        messages = list(reader.iter_decoded_messages())
    return {
        "stats": stats,
        "truth": load_truth(truth),
        "summary": summary,
        "header": header,
        "metadata": metadata,
        "messages": messages,
        "csv": csv,
        "layout": json.loads(layout.read_text(encoding="utf-8")),
    }


def by_topic(run, topic):
    return [m for m in run["messages"] if m.channel.topic == topic]


def test_the_writer_lost_nothing(run):
    stats = run["stats"]
    assert stats["produced"] == TICKS
    for sink in stats["sinks"]:
        assert (sink["written"], sink["dropped"], sink["errors"]) == (TICKS, 0, 0), sink


def test_the_summary_and_index_are_present_and_agree_with_the_messages(run):
    summary = run["summary"]
    assert summary is not None, "no summary section (PlotJuggler refuses such files)"
    assert summary.statistics is not None
    assert summary.statistics.message_count == len(run["messages"])
    assert len(summary.chunk_indexes) >= 1
    counts = Counter(m.channel.topic for m in run["messages"])
    for channel_id, count in summary.statistics.channel_message_counts.items():
        assert counts[summary.channels[channel_id].topic] == count


def test_channels_use_the_documented_encodings(run):
    channels = {c.topic: c for c in run["summary"].channels.values()}
    schemas = run["summary"].schemas
    expected = {
        "/joint_states": ("cdr", "ros2msg", "sensor_msgs/msg/JointState"),
        "/diagnostics": ("cdr", "ros2msg", "diagnostic_msgs/msg/DiagnosticArray"),
        "/motor_states": ("json", "jsonschema", "rmd_rt.MotorStates"),
        "/loop_timing": ("json", "jsonschema", "rmd_rt.LoopTiming"),
        "/signals": ("json", "jsonschema", "rmd_rt.Signals"),
    }
    assert set(channels) == set(expected)
    for topic, (encoding, schema_encoding, schema_name) in expected.items():
        channel = channels[topic]
        schema = schemas[channel.schema_id]
        assert (channel.message_encoding, schema.encoding, schema.name) == (
            encoding,
            schema_encoding,
            schema_name,
        )


def test_one_joint_state_per_record_with_the_values_and_times_written(run):
    truth = run["truth"]
    states = by_topic(run, "/joint_states")
    assert len(states) == TICKS
    for tick, m in enumerate(states):
        expected_ns = truth["start_unix_ns"] + truth["records"][tick]["since_start_ns"]
        assert m.message.log_time == expected_ns
        assert stamp_ns(m.decoded_message.header) == expected_ns
        check_joint_state(m.decoded_message, truth, tick)


def test_motor_states_validate_against_their_schema_and_match(run):
    truth = run["truth"]
    states = by_topic(run, "/motor_states")
    assert len(states) == TICKS
    schema = json.loads(states[0].schema.data)
    validator = jsonschema.Draft202012Validator(schema)
    for tick, m in enumerate(states):
        validator.validate(m.decoded_message)
        rec = truth["records"][tick]
        assert list(m.decoded_message) == truth["joints"]
        for j, joint in enumerate(truth["joints"]):
            motor = m.decoded_message[joint]
            assert motor["fresh"] == rec["fresh"][j]
            assert same(motor["current_a"], rec["current"][j] if rec["replied"][j] else None)
            assert motor["commanded_a"] == rec["commanded"][j]
            if not rec["replied"][j]:
                assert motor["reply_age_us"] is None and motor["temperature_c"] is None


def test_loop_timing_and_signals_match(run):
    truth = run["truth"]
    timing = by_topic(run, "/loop_timing")
    signals = by_topic(run, "/signals")
    assert len(timing) == len(signals) == TICKS
    t_validator = jsonschema.Draft202012Validator(json.loads(timing[0].schema.data))
    s_validator = jsonschema.Draft202012Validator(json.loads(signals[0].schema.data))
    for tick, (t, s) in enumerate(zip(timing, signals)):
        rec = truth["records"][tick]
        t_validator.validate(t.decoded_message)
        s_validator.validate(s.decoded_message)
        assert t.decoded_message["tick"] == tick
        assert t.decoded_message["work_us"] == rec["work_us"]
        assert t.decoded_message["misses"] == rec["misses"]
        assert list(s.decoded_message) == truth["signals"]
        assert list(s.decoded_message.values()) == rec["signals"]


def test_diagnostics_once_a_second_with_loop_and_motor_health(run):
    diagnostics = by_topic(run, "/diagnostics")
    assert len(diagnostics) == math.ceil(TICKS / 1000)
    levels = defaultdict(list)
    for m in diagnostics:
        statuses = m.decoded_message.status
        names = [s.name for s in statuses]
        assert names == ["rmd_rt: loop"] + [f"rmd_rt: {j}" for j in run["truth"]["joints"]]
        for s in statuses:
            levels[s.name].append(s.level)
            values = {kv.key: kv.value for kv in s.values}
            if s.name == "rmd_rt: loop":
                # Ticks 499, 1499, ... miss their deadline: two per second.
                assert "deadline misses" in s.message
                assert values["deadline_misses"] in ("1", "2")
    ok, warn = 0, 1
    assert levels["rmd_rt: loop"] == [warn] * len(diagnostics)
    assert levels["rmd_rt: hip_flexion"] == [ok] * len(diagnostics)
    # The knee misses one tick in seven: replied in ~86 % of ticks.
    assert levels["rmd_rt: knee"] == [warn] * len(diagnostics)
    assert levels["rmd_rt: ankle"] == [ok] * len(diagnostics)
    stamps = [stamp_ns(m.decoded_message.header) for m in diagnostics]
    assert stamps == sorted(stamps)


def test_the_run_layout_is_in_the_metadata(run):
    (meta,) = [m for m in run["metadata"] if m.name == "rmd_rt.run"]
    joints = json.loads(meta.metadata["joints"])
    assert [j["name"] for j in joints] == run["truth"]["joints"]
    assert [j["motor_id"] for j in joints] == [1, 2, 3]
    assert float(meta.metadata["rate_hz"]) == 1000.0
    assert int(meta.metadata["start_unix_ns"]) == run["truth"]["start_unix_ns"]


def test_the_csv_has_one_row_per_record_with_the_values_written(run):
    import csv

    truth = run["truth"]
    with open(run["csv"], newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == TICKS
    for tick in (0, 5, 3, 10, TICKS - 1):
        row, rec = rows[tick], truth["records"][tick]
        assert int(row["tick"]) == tick
        for j, joint in enumerate(truth["joints"]):
            cell = row[f"{joint}.position_rad"]
            if rec["replied"][j]:
                assert float(cell) == rec["position"][j]
            else:
                assert cell == ""
            assert row[f"{joint}.fresh"] == ("1" if rec["fresh"][j] else "0")
        for name, value in zip(truth["signals"], rec["signals"]):
            assert float(row[name]) == value


def resolve(message, path: str):
    """Evaluates the simple Foxglove message paths the layout uses: `.field` and `[index]`."""
    import re

    value = message
    for field, index in re.findall(r"\.(\w+)|\[(\d+)\]", path):
        if field:
            value = value[field] if isinstance(value, dict) else getattr(value, field)
        else:
            value = value[int(index)]
    return value


def test_every_plot_of_the_foxglove_layout_finds_numbers_in_the_file(run):
    layout = run["layout"]
    latest = {}
    for m in run["messages"]:
        latest[m.channel.topic] = m.decoded_message
    plotted = 0
    for panel_id, config in layout["configById"].items():
        if panel_id.startswith("DiagnosticSummary!"):
            assert config["topicToRender"] == "/diagnostics"
            continue
        for series in config["paths"]:
            topic, _, rest = series["value"].partition(".")
            value = resolve(latest[topic], "." + rest)
            assert isinstance(value, (int, float)) and not isinstance(value, bool), series
            plotted += 1
    # 3 angles, 2 torques (the ankle has no torque constant), 6 currents, 4 timings,
    # 3 counters, 2 signals.
    assert plotted == 20
