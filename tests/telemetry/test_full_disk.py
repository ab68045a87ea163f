"""A disk that fills up under a recording: the run ends with a non-zero status (the user asked
for a recording), the report counts only what the file holds, and the file stays readable up to
the last tick written before the failure, by the independent `mcap` reader (seeking and
streaming) and Python's csv module.

The disk is a small tmpfs mounted in a private mount namespace (`unshare -m`, as root); the
files are copied out before the namespace, and its tmpfs, go away.

Before: exit 0, "mcap: 4838 written, 0 dropped, 144 errors" and not one message readable (the
chunk in progress had a placeholder length and no end); the CSV's error count exceeded the
records offered."""

import csv
import json
import subprocess

from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap.records import Footer

from conftest import rmd_path

# 60 s of a 1 kHz loop: far more than the tmpfs holds.
TICKS = 60_000


def record_on_a_small_disk(tmp_path, size, flag, name):
    """`rmd bench loop --virtual-time` writing `flag` to `name` on a tmpfs of `size`; returns
    the exit status, the JSON report and the copied file."""
    disk, out = tmp_path / "disk", tmp_path / "out"
    disk.mkdir()
    out.mkdir()
    script = (
        f'mount -t tmpfs -o size={size} tmpfs "{disk}" || exit 99; '
        f'"$@" > "{out}/report.json"; status=$?; cp "{disk}/{name}" "{out}/"; exit $status'
    )
    done = subprocess.run(
        [
            "unshare", "-m", "sh", "-c", script, "sh", rmd_path(), "bench", "loop",
            "--virtual-time", "--seconds", str(TICKS // 1000), flag, str(disk / name), "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode != 99, f"cannot mount a tmpfs: {done.stderr}"
    report = json.loads((out / "report.json").read_text())
    return done, report, out / name


def check_sink(sink, ticks):
    assert sink["errors"] == 1, sink
    assert "No space left on device" in sink["first_error"], sink
    assert sink["failed"] > 0 and sink["dropped"] == 0, sink
    assert sink["written"] + sink["failed"] == ticks, sink


def test_a_full_disk_leaves_a_readable_mcap_and_an_honest_report(tmp_path):
    done, report, mcap = record_on_a_small_disk(tmp_path, "1m", "--mcap", "run.mcap")
    assert done.returncode == 1, done.stderr
    assert report["ticks"] == TICKS and report["stop_reason"] == "tick limit reached"
    (sink,) = report["telemetry"]
    check_sink(sink, TICKS)
    assert "mcap" in done.stderr and "failed" in done.stderr

    # The seeking reader: a complete file without summary (its footer says so), read in order.
    with open(mcap, "rb") as f:
        reader = make_reader(f)
        assert reader.get_summary() is None
        ticks = [json.loads(m.data)["tick"] for _, _, m in reader.iter_messages(topics=["/loop_timing"])]
        f.seek(0)
        states = sum(1 for _ in make_reader(f).iter_messages(topics=["/joint_states"]))
    # Every tick up to the last one written before the disk filled, none after, none missing.
    assert ticks == list(range(sink["written"])), (ticks[:3], ticks[-3:], sink)
    assert states == sink["written"]
    assert sink["written"] > 1000, "a megabyte holds a few thousand ticks"
    # The streaming reader reads it to its footer without an error.
    with open(mcap, "rb") as f:
        records = list(StreamReader(f).records)
    assert isinstance(records[-1], Footer)


def test_a_full_disk_leaves_whole_csv_rows_and_counts_them(tmp_path):
    done, report, path = record_on_a_small_disk(tmp_path, "256k", "--csv", "run.csv")
    assert done.returncode == 1, done.stderr
    (sink,) = report["telemetry"]
    check_sink(sink, report["ticks"])
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == sink["written"] > 100
    assert [int(r["tick"]) for r in rows] == list(range(len(rows)))
    # Every row is whole: its last column is there.
    assert all(r["loop.misses"] not in (None, "") for r in rows)
    assert path.read_bytes().endswith(b"\n")
