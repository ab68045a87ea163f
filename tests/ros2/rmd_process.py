"""`rmd ros2` as a process for the interoperability tests, and waiting for what it does.

Shared by test_interop.py (Cyclone DDS), test_fastdds.py (Fast DDS) and test_network.py
(`--network`). The binary comes from $RMD_BIN; the robot is examples/robots/leg4.toml on
simulated motors in real time, with the servo settings of leg4_servo.toml.
"""

import json
import os
import signal
import subprocess
import time

JOINTS = ["hip_aa", "hip_fe", "knee", "ankle"]
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
ROBOT = os.path.join(ROOT, "examples", "robots", "leg4.toml")
SERVO = os.path.join(ROOT, "tests", "ros2", "leg4_servo.toml")
TIMEOUT = 30.0
# How close a joint must come to a commanded position (the servo's PD on an unloaded simulated
# joint settles far closer; this leaves room for a loaded machine).
TOL = 0.01
REJECTION_KINDS = ["unknown_joint", "not_finite", "out_of_limit", "length_mismatch", "empty",
                   "duplicate_joint", "bad_time", "unsupported", "infeasible", "malformed",
                   "port_refused", "oversized"]


# The `rmd ros2` processes running now: a wait fails at once, with their report, when one ended
# before its time.
RUNNING = []


def wait_until(what, predicate, timeout=TIMEOUT, poll=0.02):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        for r in RUNNING:
            if r.proc.poll() is not None:
                code, report, err = r.wait()
                raise AssertionError(
                    f"rmd ros2 ended (exit {code}) while waiting for {what}: "
                    f"{report and report.get('stop_reason')}\n{err}")
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def raised_priority():
    """`nice -n -15` where allowed (root): the tests run side by side with every other suite, and
    the motors are simulated in real time. At normal priority on that loaded machine the loop
    thread can be left unscheduled for tens of milliseconds while a simulated motor goes on with
    its last torque, and the loop's guard then rightly ends the run (a joint past its velocity
    limit). What is tested here is DDS, not the host's scheduler. (A higher weight, not
    SCHED_FIFO: the node's threads still share the CPU with each other.) `nice` execs the
    node, so the process is the node's."""
    return ["nice", "-n", "-15"] if os.geteuid() == 0 else []


class Rmd:
    """`rmd ros2` as a process (at `raised_priority` where allowed): the report comes as JSON on
    stdout when it ends."""

    def __init__(self, *extra, namespace, domain, network="127.0.0.1"):
        binary = os.environ["RMD_BIN"]
        self.proc = subprocess.Popen(
            [*raised_priority(), binary, "ros2", "--robot", ROBOT, "--sim", "--servo", SERVO,
             "--namespace", namespace, "--domain-id", str(domain), "--network", network,
             "--diagnostics-period", "300ms", "--json", *extra],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.result = None
        RUNNING.append(self)

    def wait(self):
        """The exit code, the report and stderr, once the process ended by itself."""
        if self.result is None:
            if self in RUNNING:
                RUNNING.remove(self)
            out, err = self.proc.communicate(timeout=TIMEOUT)
            report = json.loads(out) if out.strip() else None
            self.result = (self.proc.returncode, report, err)
        return self.result

    def interrupt(self):
        """Ctrl-C: the loop stops (zero torque, motor off), the node says goodbye."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        return self.wait()

    def rss_kib(self):
        """The process's resident memory now, KiB."""
        with open(f"/proc/{self.proc.pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
        raise AssertionError("no VmRSS line")

    def kill(self):
        if self in RUNNING:
            RUNNING.remove(self)
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


def module_node(namespace, domain):
    """A test module's `rmd ros2` (for a module-scoped fixture: `yield from`), killed at the
    end."""
    r = Rmd(namespace=namespace, domain=domain)
    try:
        yield r
    finally:
        r.kill()
