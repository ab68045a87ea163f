//! Every printing command survives a closed pipe (`rmd status --sim 1-4 | head -2`): no panic
//! (exit 101, "panicked" on stderr), no hang; the command stops writing and ends quietly, and
//! a command that moved a motor still turns it off.
//!
//! Each command runs with its stdout a pipe that this test closes, either before the command
//! writes anything (every write then fails with EPIPE: deterministic) or after reading its first
//! line (as `head -1` does). A few run with stderr closed instead.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rmd_bus::candump::{FrameDirection, parse_line};
use rmd_protocol::{Command as Cmd, DecodedRequest, Dialect};

/// The longest a command may take (a hang is a failure, not a timing goal).
const LIMIT: Duration = Duration::from_secs(60);

/// Which end of the command the test closes.
#[derive(Copy, Clone, Debug)]
enum Close {
    /// stdout, before the command writes anything.
    StdoutAtOnce,
    /// stdout, after reading the first line.
    StdoutAfterFirstLine,
    /// stderr, at once.
    StderrAtOnce,
}

/// How a run ended.
struct Ended {
    code: Option<i32>,
    /// What the test did not close, read to the end.
    other: String,
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_rmd"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start rmd")
}

/// Runs `rmd ARGS`, closes one end as `close` says, and waits for the end.
fn run(args: &[&str], close: Close) -> Ended {
    let mut child = spawn(args);
    let stdout = child.stdout.take().unwrap();
    let stderr = child.stderr.take().unwrap();
    // Read what stays open on a thread, so that a full pipe never blocks the command.
    let (kept, closed): (Box<dyn Read + Send>, Box<dyn Read + Send>) = match close {
        Close::StdoutAtOnce | Close::StdoutAfterFirstLine => (Box::new(stderr), Box::new(stdout)),
        Close::StderrAtOnce => (Box::new(stdout), Box::new(stderr)),
    };
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        let mut kept = kept;
        let _ = kept.read_to_string(&mut text);
        text
    });
    match close {
        Close::StdoutAtOnce | Close::StderrAtOnce => drop(closed),
        Close::StdoutAfterFirstLine => {
            let mut first = String::new();
            let mut lines = BufReader::new(closed);
            lines.read_line(&mut first).unwrap();
            assert!(!first.is_empty(), "rmd {}: no first line", args.join(" "));
            drop(lines);
        }
    }
    let start = Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if start.elapsed() > LIMIT {
            let _ = child.kill();
            panic!(
                "rmd {} did not end after its {close:?} closed",
                args.join(" ")
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Ended {
        code,
        other: reader.join().unwrap(),
    }
}

/// Runs `rmd ARGS` with `close`, asserting a quiet end with status `code`.
fn quiet_end(args: &[&str], close: Close, code: i32) {
    let ended = run(args, close);
    assert!(
        !ended.other.contains("panicked"),
        "rmd {} ({close:?}): {}",
        args.join(" "),
        ended.other
    );
    assert_ne!(ended.code, Some(101), "rmd {} ({close:?})", args.join(" "));
    assert_eq!(
        ended.code,
        Some(code),
        "rmd {} ({close:?}): {}",
        args.join(" "),
        ended.other
    );
}

/// A fresh file path in a per-test directory.
fn temp_path(test: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rmd-pipes-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The last command the host sent to `motor` in a `--log` recording.
fn last_command_to(log: &Path, motor: u8) -> Option<Cmd> {
    std::fs::read_to_string(log)
        .unwrap()
        .lines()
        .rev()
        .filter_map(|l| parse_line(l).ok())
        .filter(|l| l.direction == Some(FrameDirection::Tx))
        .filter_map(|l| match Dialect::V161.decode_request(&l.frame) {
            Ok(DecodedRequest::Single { motor: m, request }) if m.get() == motor => {
                Some(request.command())
            }
            _ => None,
        })
        .next()
}

/// A candump -L log of many frames (status reads of four motors, recorded by `rmd` itself).
fn recorded_session(test: &str) -> PathBuf {
    let log = temp_path(test, "session.log");
    let out = Command::new(env!("CARGO_BIN_EXE_rmd"))
        .args(["status", "1-4", "--sim", "--log", log.to_str().unwrap()])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(out.status.success());
    log
}

#[test]
fn status_piped_into_head_ends_quietly() {
    // `rmd status --sim 1-4 | head -2`.
    for close in [Close::StdoutAtOnce, Close::StdoutAfterFirstLine] {
        quiet_end(&["status", "--sim", "1-4"], close, 0);
        quiet_end(&["status", "--sim", "1-4", "--json"], close, 0);
    }
}

#[test]
fn reading_commands_end_quietly() {
    let commands: &[&[&str]] = &[
        &["encode", "read-status-1", "--id", "1"],
        &["scan", "--sim"],
        &["scan", "--sim", "--json"],
        &["pid", "get", "1", "--sim"],
        &["pid", "get", "1", "--sim", "--json"],
        &["accel", "get", "2", "--sim"],
        &["encoder", "get", "3", "--sim"],
        &["traj", "--help"],
        &["--help"],
        &["completions", "bash"],
        &["completions", "zsh"],
    ];
    for args in commands {
        quiet_end(args, Close::StdoutAtOnce, 0);
    }
    quiet_end(&["scan", "--sim"], Close::StdoutAfterFirstLine, 0);
    quiet_end(&["completions", "fish"], Close::StdoutAfterFirstLine, 0);
}

#[test]
fn writing_commands_end_quietly() {
    let commands: &[&[&str]] = &[
        &["pid", "set", "1", "--speed-pid-kp", "60", "--sim"],
        &["accel", "set", "1", "1000", "--sim"],
        &["encoder", "offset", "1", "--here", "--sim"],
        &["zero", "1", "--yes", "--sim"],
        &["off", "1-4", "--sim"],
        &["stop", "1-4", "--sim"],
        &["run", "1-4", "--sim"],
    ];
    for args in commands {
        quiet_end(args, Close::StdoutAtOnce, 0);
    }
    quiet_end(
        &["off", "all", "--sim", "--sim-ids", "1-32"],
        Close::StdoutAfterFirstLine,
        0,
    );
}

#[test]
fn motion_commands_still_turn_the_motor_off() {
    let log = temp_path("motion", "bus.log");
    let log_arg = log.to_str().unwrap();
    for close in [Close::StdoutAtOnce, Close::StderrAtOnce] {
        for (args, motor) in [
            (
                &[
                    "torque",
                    "2",
                    "--amps",
                    "0.3",
                    "--duration",
                    "150ms",
                    "--sim",
                    "--log",
                    log_arg,
                ][..],
                2,
            ),
            (
                &[
                    "speed",
                    "3",
                    "--dps",
                    "90",
                    "--duration",
                    "150ms",
                    "--sim",
                    "--log",
                    log_arg,
                ][..],
                3,
            ),
        ] {
            quiet_end(args, close, 0);
            assert_eq!(
                last_command_to(&log, motor),
                Some(Cmd::MotorOff),
                "{args:?}"
            );
        }
        // A move that fails to arrive in time turns the motor off, closed output or not.
        let ended = run(
            &[
                "move",
                "1",
                "--deg",
                "3600",
                "--wait-timeout",
                "100ms",
                "--sim",
                "--log",
                log_arg,
            ],
            close,
        );
        assert_eq!(ended.code, Some(1));
        assert!(!ended.other.contains("panicked"), "{}", ended.other);
        assert_eq!(last_command_to(&log, 1), Some(Cmd::MotorOff));
        // A move that arrives holds the position, as it would with the output open.
        quiet_end(&["move", "1", "--deg", "1", "--sim"], close, 0);
    }
}

#[test]
fn monitor_stops_when_nobody_reads() {
    // Without --count the monitor runs until Ctrl-C: a closed stdout must end it.
    for close in [Close::StdoutAtOnce, Close::StdoutAfterFirstLine] {
        quiet_end(
            &["monitor", "--sim", "--ids", "1-2", "--rate", "50"],
            close,
            0,
        );
        quiet_end(
            &["monitor", "--sim", "--ids", "1-2", "--rate", "50", "--json"],
            close,
            0,
        );
    }
}

#[test]
fn decode_and_replay_end_quietly() {
    let log = recorded_session("decode");
    let log_arg = log.to_str().unwrap();
    for close in [Close::StdoutAtOnce, Close::StdoutAfterFirstLine] {
        quiet_end(&["decode", log_arg], close, 0);
        quiet_end(&["replay", log_arg, "--fast"], close, 0);
        quiet_end(&["replay", log_arg, "--speed", "4"], close, 0);
        quiet_end(&["replay", log_arg, "--fast", "--sim"], close, 0);
    }
}

#[test]
fn bench_and_traj_end_quietly() {
    let vectors = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../rmd-traj-vectors/tests/data/regressions.json"
    );
    let commands: &[&[&str]] = &[
        &["bench", "loop", "--virtual-time", "--duration", "100ms"],
        &[
            "bench",
            "loop",
            "--virtual-time",
            "--duration",
            "100ms",
            "--json",
        ],
        &["bench", "jitter", "--duration", "50ms"],
        &[
            "bench",
            "rate",
            "--virtual-time",
            "--rate",
            "1000",
            "--duration",
            "100ms",
        ],
        &["traj", "check", vectors],
    ];
    for args in commands {
        quiet_end(args, Close::StdoutAtOnce, 0);
        quiet_end(args, Close::StderrAtOnce, 0);
    }
}

#[test]
fn messages_on_a_closed_stderr_do_not_stop_the_work() {
    // scan reports its summary on stderr; the table still comes out on stdout.
    let ended = run(&["scan", "--sim"], Close::StderrAtOnce);
    assert_eq!(ended.code, Some(0));
    assert!(ended.other.lines().count() >= 5, "{}", ended.other);
    // An error message that nobody can read still gives the error's exit status.
    let ended = run(
        &["status", "9", "--sim", "--timeout-ms", "5"],
        Close::StderrAtOnce,
    );
    assert_eq!(ended.code, Some(1));
    let ended = run(&["status", "--sim"], Close::StderrAtOnce);
    assert_eq!(ended.code, Some(2));
}
