"""A writer that dies leaves a readable file; a writer that is told to stop closes it cleanly.

SIGKILL: the complete chunks written before the kill are read back with the streaming reader of
the `mcap` package (what a recovery tool does: read records until the file ends mid-record), and
every message in them decodes and matches the truth. SIGTERM: the writer's signal handling stops
the run and the file is complete, with summary.
"""

import signal
import subprocess
import time

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
from mcap.stream_reader import StreamReader

from conftest import check_joint_state, decoder_factories, load_truth, synth_args

SMALL_CHUNKS = 4096  # bytes: chunks complete every few ticks


def start_writer(tmp_path, *extra):
    mcap, truth = tmp_path / "run.mcap", tmp_path / "truth.json"
    # 15 s of ticks at 1 kHz, paced: the test stops it long before the end.
    args = synth_args(
        "--ticks", 15_000, "--realtime", "--mcap", mcap, "--chunk-size", SMALL_CHUNKS, *extra,
        truth=truth,
    )
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return process, mcap, truth


def wait_for_bytes(process, path, size, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        if path.exists() and path.stat().st_size >= size:
            return
        time.sleep(0.05)
    raise AssertionError(f"{path} did not reach {size} bytes in {timeout} s")


def salvage(path):
    """Every record of the file up to where it breaks off, and how it ended."""
    records, ending = [], "complete"
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, emit_chunks=True).records:
                records.append(record)
        except (McapError, EOFError, ValueError) as error:  # truncated mid-record
            ending = f"truncated: {type(error).__name__}"
    return records, ending


def test_a_killed_writer_leaves_its_complete_chunks_readable(tmp_path):
    process, mcap, truth_path = start_writer(tmp_path)
    wait_for_bytes(process, mcap, 64 * 1024)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=10)
    assert process.returncode == -signal.SIGKILL

    records, ending = salvage(mcap)
    assert ending.startswith("truncated") or not any(isinstance(r, Footer) for r in records)
    assert not any(isinstance(r, (DataEnd, Footer)) for r in records), "the file was finished"
    chunks = [r for r in records if isinstance(r, Chunk)]
    assert len(chunks) >= 3, f"only {len(chunks)} complete chunks before the kill"

    # Read the complete chunks' messages, as a recovery would.
    from mcap.stream_reader import breakup_chunk

    schemas, channels, messages = {}, {}, []
    for record in records:
        inner = breakup_chunk(record, validate_crc=True) if isinstance(record, Chunk) else [record]
        for r in inner:
            if isinstance(r, Schema):
                schemas[r.id] = r
            elif isinstance(r, Channel):
                channels[r.id] = r
            elif isinstance(r, Message):
                messages.append(r)
    truth = load_truth(truth_path)
    decoders = {}
    topics = set()
    ticks = []
    for m in messages:
        channel = channels[m.channel_id]
        topics.add(channel.topic)
        if m.channel_id not in decoders:
            schema = schemas.get(channel.schema_id)
            decoders[m.channel_id] = next(
                d
                for d in (f.decoder_for(channel.message_encoding, schema) for f in decoder_factories())
                if d is not None
            )
        decoded = decoders[m.channel_id](m.data)  # every message decodes
        if channel.topic == "/joint_states":
            tick = (m.log_time - truth["start_unix_ns"]) // 1_000_000
            check_joint_state(decoded, truth, tick)
            ticks.append(tick)
    assert {"/joint_states", "/motor_states", "/loop_timing", "/signals"} <= topics
    assert len(ticks) >= 50
    assert ticks == sorted(ticks) and ticks[0] == 0


def test_a_writer_stopped_by_sigterm_closes_the_file_with_its_summary(tmp_path):
    process, mcap, truth_path = start_writer(tmp_path)
    wait_for_bytes(process, mcap, 32 * 1024)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=30)
    assert process.returncode == 0, err
    import json

    stats = json.loads(out.strip().splitlines()[-1])
    (mcap_stats,) = stats["sinks"]
    assert 0 < stats["produced"] < 15_000
    assert mcap_stats["written"] + mcap_stats["dropped"] == stats["produced"]

    with open(mcap, "rb") as f:
        reader = make_reader(f, decoder_factories=decoder_factories())
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        states = list(reader.iter_decoded_messages(topics=["/joint_states"]))
    assert len(states) == mcap_stats["written"]
    truth = load_truth(truth_path)
    for m in states:
        tick = (m.message.log_time - truth["start_unix_ns"]) // 1_000_000
        check_joint_state(m.decoded_message, truth, tick)
