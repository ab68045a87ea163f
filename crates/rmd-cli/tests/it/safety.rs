//! The live commands end as a robotics engineer expects, whatever the flags, the log or the log's
//! reader do (simulated motors in the process, `--sim`):
//! - `--duration` of `rmd torque` / `rmd speed` is wall-clock time, whatever `--rate` asks;
//! - `rmd replay` asks before sending frames that write a motor's ROM, and refuses without a
//!   terminal unless `--yes`, naming the frames;
//! - a `--log` FIFO whose reader stops reading never holds the end of a command, nor its
//!   signals;
//! - SIGTERM ends `rmd torque`, `speed` and `move` with status 130 after motor-off.
//!
//! Time bounds here are far above the expected times: they catch hangs, not slowness.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command as StdCommand, Stdio};
use std::time::{Duration, Instant};

use rmd_bus::candump::{FrameDirection, parse_line};
use rmd_protocol::{Command as Cmd, DecodedRequest, Dialect};

use crate::support;
use support::{fails, ok, rmd, text};

/// A fresh file path in a per-test directory.
fn temp_path(test: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rmd-safety-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

/// The recorded frames of a `--log` file: direction, motor id (single-motor frames), command.
fn frames(path: &Path) -> Vec<(FrameDirection, u16, u8)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|line| {
            let parsed = parse_line(line).unwrap_or_else(|e| panic!("{line}: {e}"));
            (
                parsed.direction.expect("the recorder writes directions"),
                parsed.frame.id(),
                parsed.frame.data()[0],
            )
        })
        .collect()
}

/// The host's single-motor requests of a log: (motor, command).
fn host_commands(path: &Path) -> Vec<(u8, Cmd)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|line| parse_line(line).unwrap())
        .filter(|l| l.direction == Some(FrameDirection::Tx))
        .filter_map(|l| match Dialect::V161.decode_request(&l.frame) {
            Ok(DecodedRequest::Single { motor, request }) => Some((motor.get(), request.command())),
            _ => None,
        })
        .collect()
}

/// Asserts that the log ends with motor-off to `motor`, confirmed by the motor.
fn ends_with_confirmed_motor_off(path: &Path, motor: u8) {
    let recorded = frames(path);
    let id = 0x140 + u16::from(motor);
    let off = Cmd::MotorOff.code();
    assert!(
        recorded.ends_with(&[(FrameDirection::Tx, id, off), (FrameDirection::Rx, id, off)]),
        "{:?}",
        &recorded[recorded.len().saturating_sub(4)..]
    );
}

/// Waits for `child` to exit, at most `limit` (a hang is a failure); returns its status code.
fn wait_exit(child: &mut Child, limit: Duration, what: &str) -> i32 {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status.code().expect("exited normally");
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A running `rmd`, killed if the test fails before it ended.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

impl std::ops::Deref for Running {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Running {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

/// Starts `rmd ARGS` with stdout and stderr piped.
fn spawn(args: &[&str]) -> Running {
    Running(
        StdCommand::new(env!("CARGO_BIN_EXE_rmd"))
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    )
}

/// `child`'s stderr, read by a thread, so that waiting for a line is bounded.
struct Stderr {
    lines: std::sync::mpsc::Receiver<String>,
    seen: String,
}

impl Stderr {
    fn of(child: &mut Child) -> Self {
        let reader = BufReader::new(child.stderr.take().unwrap());
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in reader.lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self {
            lines,
            seen: String::new(),
        }
    }

    /// Waits (at most `limit`: a hang is a failure) for a line containing `ready`.
    fn await_line(&mut self, ready: &str, limit: Duration) {
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    let found = line.contains(ready);
                    self.seen.push_str(&line);
                    self.seen.push('\n');
                    if found {
                        return;
                    }
                }
                Err(_) => panic!("no `{ready}` within {limit:?}: {}", self.seen),
            }
        }
    }

    /// Everything after the line awaited, once the command ended.
    fn rest(self) -> String {
        self.lines.iter().collect::<Vec<_>>().join("\n")
    }
}

fn rest(mut reader: impl Read) -> String {
    let mut text = String::new();
    reader.read_to_string(&mut text).unwrap();
    text
}

fn send(child: &Child, signal: nix::sys::signal::Signal) {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).unwrap());
    nix::sys::signal::kill(pid, signal).unwrap();
}

#[test]
fn drive_duration_is_wall_clock_time_at_any_rate() {
    for (command, setpoint) in [("torque", ["--amps", "0.2"]), ("speed", ["--dps", "90"])] {
        let log = temp_path("rate", &format!("{command}.log"));
        let started = Instant::now();
        let out = ok(&[
            command,
            "2",
            setpoint[0],
            setpoint[1],
            "--duration",
            "1s",
            "--rate",
            "20000",
            "--sim",
            "--log",
            log.to_str().unwrap(),
        ]);
        let took = started.elapsed();
        // 1 s of driving ends long before the 10 s that 20 000 commands take (each waits for
        // its reply); the bound only catches the old behaviour.
        assert!(took < Duration::from_secs(6), "{command}: {took:?}");
        assert!(out.contains("is more than the motor answers"), "{out}");
        let commands = host_commands(&log);
        let driven = commands.iter().filter(|c| c.1 != Cmd::MotorOff).count();
        assert!(
            driven > 1 && driven < 20_000,
            "{command}: {driven} commands"
        );
        ends_with_confirmed_motor_off(&log, 2);
    }
}

/// A log holding a zero write (0x19) to motor 1 and a PID write to ROM (0x32) to motor 2, each
/// with its reply.
fn rom_log(test: &str) -> PathBuf {
    let log = temp_path(test, "rom.log");
    std::fs::write(
        &log,
        "(1.000000) can0 141#1900000000000000 T\n\
         (1.000300) can0 141#1900000000001234 R\n\
         (1.001000) can0 141#9C00000000000000 T\n\
         (1.001300) can0 141#9C19000000000000 R\n\
         (1.002000) can0 142#3200640A64286432 T\n\
         (1.002300) can0 142#3200640A64286432 R\n",
    )
    .unwrap();
    log
}

#[test]
fn replaying_rom_writes_asks_first_and_refuses_without_a_terminal() {
    let log = rom_log("replay-rom");
    let file = log.to_str().unwrap();
    let session = temp_path("replay-rom", "session.log");
    let session_arg = session.to_str().unwrap();
    // No terminal, no --yes: refused before anything is opened or sent, naming the frames.
    let err = fails(1, &["replay", file, "--sim", "--log", session_arg]);
    assert!(err.contains("needs confirmation"), "{err}");
    assert!(err.contains("pass --yes"), "{err}");
    assert!(
        err.contains("line 1: 0x19") && err.contains("to motor 1"),
        "{err}"
    );
    assert!(
        err.contains("line 5: 0x32") && err.contains("to motor 2"),
        "{err}"
    );
    assert!(!err.contains("line 3"), "a read is not a ROM write: {err}");
    assert!(!session.exists(), "nothing may be sent");
    // Replies travel on the motors' ids too: replaying them writes ROM as well.
    let err = fails(1, &["replay", file, "--sim", "--frames", "motors"]);
    assert!(
        err.contains("line 2: 0x19") && err.contains("line 6: 0x32"),
        "{err}"
    );
    // Confirmed with --yes: sent, and the simulated motors answered both.
    let out = rmd(&["replay", file, "--sim", "--yes", "--log", session_arg]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        host_commands(&session),
        [
            (1, Cmd::WriteZeroRom),
            (1, Cmd::ReadStatus2),
            (2, Cmd::WritePidRom)
        ]
    );
    let answered: Vec<u8> = frames(&session)
        .iter()
        .filter(|f| f.0 == FrameDirection::Rx)
        .map(|f| f.2)
        .collect();
    assert_eq!(answered, [0x19, 0x9C, 0x32]);
    // Printing the log never asks.
    let printed = ok(&["replay", file, "--fast"]);
    assert_eq!(printed.lines().count(), 6);
}

/// A FIFO whose reader holds it open and never reads, already full: the first write of a
/// command's `--log` to it would block. Returns the FIFO's path and the reader (keep it alive).
#[cfg(target_os = "linux")]
fn stalled_fifo(test: &str) -> (PathBuf, std::fs::File) {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let path = temp_path(test, "bus.fifo");
    nix::unistd::mkfifo(&path, nix::sys::stat::Mode::from_bits_truncate(0o600)).unwrap();
    // Read and write: opening does not wait for another end, and the FIFO stays open for
    // reading (by us, who never read).
    let mut fifo = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(nix::fcntl::OFlag::O_NONBLOCK.bits())
        .open(&path)
        .unwrap();
    let chunk = [b'#'; 4096];
    loop {
        match fifo.write(&chunk) {
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
            Err(e) => panic!("filling the FIFO: {e}"),
        }
    }
    (path, fifo)
}

#[cfg(target_os = "linux")]
#[test]
fn a_stalled_log_reader_does_not_hold_the_end_of_a_command() {
    let (fifo, _reader) = stalled_fifo("stalled-log");
    let mut child = spawn(&[
        "torque",
        "1",
        "--amps",
        "0.2",
        "--duration",
        "0.5s",
        "--sim",
        "--log",
        fifo.to_str().unwrap(),
    ]);
    let code = wait_exit(&mut child, Duration::from_secs(30), "rmd torque --log FIFO");
    let stdout = rest(child.stdout.take().unwrap());
    let stderr = rest(child.stderr.take().unwrap());
    assert_eq!(code, 1, "{stderr}");
    // The motor was turned off (and confirmed) before the wait for the log.
    assert!(stdout.contains("then turned off"), "{stdout}");
    assert!(
        stderr.contains("is not reading: waiting at most 5 s"),
        "{stderr}"
    );
    assert!(
        stderr.contains("frame(s) were not written to") && stderr.contains("(0 written)"),
        "{stderr}"
    );
    assert!(stderr.contains("gave up 5 s after the end"), "{stderr}");
    // Every frame of the run is counted: at least the torque commands and motor-off, each
    // with its reply.
    let lost: u64 = stderr
        .split("error: ")
        .nth(1)
        .and_then(|e| e.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count in {stderr}"));
    assert!(lost >= 4, "{stderr}");
}

#[cfg(target_os = "linux")]
#[test]
fn a_signal_ends_the_wait_for_a_stalled_log_reader() {
    use nix::sys::signal::Signal;
    let (fifo, _reader) = stalled_fifo("stalled-log-signal");
    let mut child = spawn(&[
        "torque",
        "1",
        "--amps",
        "0.2",
        "--duration",
        "0.2s",
        "--sim",
        "--log",
        fifo.to_str().unwrap(),
    ]);
    let mut stderr = Stderr::of(&mut child);
    stderr.await_line("is not reading: waiting", Duration::from_secs(30));
    send(&child, Signal::SIGTERM);
    let code = wait_exit(
        &mut child,
        Duration::from_secs(30),
        "rmd torque after SIGTERM",
    );
    let stderr = stderr.rest();
    let stdout = rest(child.stdout.take().unwrap());
    assert_eq!(code, 130, "{stderr}");
    assert!(stderr.contains("interrupted: "), "{stderr}");
    assert!(stderr.contains("stopped waiting for it"), "{stderr}");
    assert!(stderr.contains("frame(s) were not written"), "{stderr}");
    assert!(stdout.contains("then turned off"), "{stdout}");
}

#[cfg(target_os = "linux")]
#[test]
fn sigterm_ends_torque_speed_and_move_with_130_after_motor_off() {
    use nix::sys::signal::Signal;
    for (test, args) in [
        (
            "term-torque",
            &["torque", "3", "--amps", "0.3", "--duration", "60s"][..],
        ),
        (
            "term-speed",
            &["speed", "3", "--dps", "360", "--duration", "60s"],
        ),
    ] {
        let log = temp_path(test, "bus.log");
        let mut args = args.to_vec();
        args.extend(["--sim", "--log", log.to_str().unwrap()]);
        let mut child = spawn(&args);
        let mut stderr = Stderr::of(&mut child);
        stderr.await_line("Ctrl-C stops it", Duration::from_secs(30));
        send(&child, Signal::SIGTERM);
        let code = wait_exit(&mut child, Duration::from_secs(30), test);
        let stderr = stderr.rest();
        assert_eq!(code, 130, "{test}: {stderr}");
        assert!(stderr.contains("motor 3 turned off"), "{test}: {stderr}");
        ends_with_confirmed_motor_off(&log, 3);
    }
    // A move: once the position command was answered.
    let log = temp_path("term-move", "bus.log");
    let mut child = spawn(&[
        "move",
        "1",
        "--deg",
        "3600",
        "--max-speed",
        "10",
        "--sim",
        "--log",
        log.to_str().unwrap(),
    ]);
    let start = Instant::now();
    while !std::fs::read_to_string(&log)
        .unwrap_or_default()
        .contains("141#A4")
    {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "the move never started"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    send(&child, Signal::SIGTERM);
    assert_eq!(wait_exit(&mut child, Duration::from_secs(30), "move"), 130);
    ends_with_confirmed_motor_off(&log, 1);
}
