"""The signal policy of every long-running command, whatever state stderr is in: a closed pipe
(EPIPE), a full disk (`/dev/full`, ENOSPC), a hung-up terminal (the master of its pty closed:
the kernel sends SIGHUP, and every later write fails with EIO). The first signal stops the run:
the command ends with status 130, prints its report on stdout, and its MCAP file is finished
(summary and all), read back by the independent `mcap` reader. `rmd drill` also says, from the
simulated firmware's ground truth, that no motor is left energised.

Before the signal handler stopped printing, the print failed on these stderrs, the handler
thread died and the run went on to its limit; `rmd bench loop` and `rmd drill` had no signal
policy at all (killed, their MCAP files without summary)."""

import fcntl
import json
import os
import pty
import select
import signal
import subprocess
import termios
import threading
import time

import pytest
from mcap.reader import make_reader

from conftest import pd_hold_path, rmd_path

# A run that would last far longer than the test waits. The loops run on virtual time: the
# subject is the signal, and simulated motors on threads of their own miss replies when a
# loaded machine does not run them (a real fault of the run, not of the signal policy).
LONG_S = 3000
# The most a command may take to stop after its signal (a hang is the failure, not a timing goal).
STOP_WITHIN_S = 60


def command(name, tmp_path):
    """The command line of `name` (recording to an MCAP file where it can) and that file."""
    mcap = tmp_path / "run.mcap"
    if name == "bench loop":
        return [
            rmd_path(), "bench", "loop", "--virtual-time", "--seconds", LONG_S, "--mcap", mcap,
            "--json",
        ], mcap
    if name == "drill":
        return [
            rmd_path(), "drill", "--virtual-time", "--fault", f"estop@{LONG_S - 1}", "--seconds",
            LONG_S, "--mcap", mcap, "--json",
        ], mcap
    if name == "pd_hold":
        return [
            pd_hold_path(), "--virtual-time", "--duration", LONG_S, "--mcap", mcap, "--json",
        ], mcap
    if name == "replay":
        log = tmp_path / "slow.log"
        log.write_text(
            "".join(f"({1000 + k * 0.5:.6f}) can0 141#9C00000000000000\n" for k in range(240))
        )
        return [rmd_path(), "replay", log], None
    raise AssertionError(name)


def started(process, mcap, out_path):
    """Waits until the run is under way: its MCAP file holds a chunk, or (replay) it printed."""
    deadline = time.monotonic() + STOP_WITHIN_S
    while time.monotonic() < deadline:
        assert process.poll() is None, f"ended early with {process.returncode}: {out_path.read_text()}"
        if mcap is None and out_path.stat().st_size > 0:
            return
        # Header and metadata are a few hundred bytes; the first chunk follows within a second.
        if mcap is not None and mcap.exists() and mcap.stat().st_size > 4096:
            return
        time.sleep(0.05)
    raise AssertionError("the run never got under way")


def make_controlling_terminal():
    """In the child, after setsid: its stdin (the pty) becomes its controlling terminal."""
    fcntl.ioctl(0, termios.TIOCSCTTY, 0)


def run_and_stop(argv, mcap, out_path, stderr_kind):
    """Starts `argv` with the dead stderr `stderr_kind`, stops it as that kind allows (SIGTERM,
    SIGINT, or hanging up its terminal) once under way; returns the exit status."""
    args = [str(a) for a in argv]
    with open(out_path, "w", encoding="utf-8") as out:
        if stderr_kind == "hung-up pty":
            master, slave = pty.openpty()
            process = subprocess.Popen(
                args, stdin=slave, stdout=out, stderr=slave, start_new_session=True,
                preexec_fn=make_controlling_terminal,
            )
            os.close(slave)

            # Read what it draws (a person watching), so that a full pty never holds it. The
            # reader must be gone before the master is closed: a read in progress would keep
            # the terminal open.
            watching = threading.Event()
            watching.set()

            def drain():
                while watching.is_set():
                    ready, _, _ = select.select([master], [], [], 0.05)
                    if ready:
                        try:
                            os.read(master, 4096)
                        except OSError:
                            return

            reader = threading.Thread(target=drain, daemon=True)
            reader.start()
            started(process, mcap, out_path)
            watching.clear()
            reader.join()
            # The terminal goes away (an SSH session that dropped): SIGHUP, then EIO on writes.
            os.close(master)
        else:
            if stderr_kind == "closed pipe":
                process = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.PIPE)
                process.stderr.close()
                stop = signal.SIGTERM
            else:
                full = open("/dev/full", "w", encoding="utf-8")
                process = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=out, stderr=full)
                full.close()
                stop = signal.SIGINT
            started(process, mcap, out_path)
            process.send_signal(stop)
        try:
            return process.wait(timeout=STOP_WITHIN_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            what = " ".join([os.path.basename(args[0]), args[1]])
            raise AssertionError(f"{what} did not stop on its signal ({stderr_kind})") from None


def read_mcap(path):
    """The summary and the /loop_timing ticks of a finished MCAP file."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        ticks = [json.loads(m.data)["tick"] for _, _, m in reader.iter_messages(topics=["/loop_timing"])]
    return summary, ticks


@pytest.mark.parametrize("stderr_kind", ["closed pipe", "/dev/full", "hung-up pty"])
@pytest.mark.parametrize("name", ["bench loop", "drill", "pd_hold", "replay"])
def test_the_first_signal_stops_the_run_whatever_stderr_is(tmp_path, name, stderr_kind):
    argv, mcap = command(name, tmp_path)
    out_path = tmp_path / "stdout.txt"
    status = run_and_stop(argv, mcap, out_path, stderr_kind)
    out = out_path.read_text()
    assert status == 130, f"{name} ({stderr_kind}): exit {status}\n{out}"
    if name == "replay":
        assert 0 < len(out.splitlines()) < 240, "stopped part way"
        return

    report = json.loads(out)
    assert report["stop_reason"] == "stop requested", report["stop_reason"]
    summary, ticks = read_mcap(mcap)
    assert summary is not None, "the MCAP file was finished with its summary"
    assert summary.statistics.message_count > 0
    assert ticks == sorted(ticks) and len(ticks) > 0
    if name == "drill":
        # The simulated firmware's ground truth, not the loop's belief.
        assert report["motors_energised_after"] == 0, report
        assert report["confirmed_off"] == report["motors"], report
    if "telemetry" in report:
        (sink,) = report["telemetry"]
        # The report counts what the file holds.
        assert sink["written"] == len(ticks), (sink, len(ticks))
        assert (sink["failed"], sink["errors"]) == (0, 0), sink
