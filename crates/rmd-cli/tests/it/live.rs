//! The live-bus commands against simulated motors in the process (`--sim`, real time): what
//! they print, what they send (checked in the `--log` recording), their errors, confirmations,
//! and the motor being turned off at the end and on Ctrl-C. No assertion depends on timing.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command as StdCommand, Stdio};
use std::time::{Duration, Instant};

use rmd_bus::candump::{FrameDirection, parse_line};
use rmd_protocol::{Command as Cmd, DecodedRequest, Dialect, Reply};
use serde_json::Value;

use crate::support;
use support::{fails, ok, rmd, text};

fn json_lines(stdout: &str) -> Vec<Value> {
    stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

/// A fresh log file path in a per-test directory.
fn log_path(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rmd-live-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join("bus.log")
}

/// One recorded frame: direction and the frame.
struct Logged {
    direction: FrameDirection,
    frame: rmd_protocol::CanFrame,
}

fn read_log(path: &Path) -> Vec<Logged> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|line| {
            let parsed = parse_line(line).unwrap_or_else(|e| panic!("{line}: {e}"));
            Logged {
                direction: parsed.direction.expect("the recorder writes directions"),
                frame: parsed.frame,
            }
        })
        .collect()
}

/// The commands of the host's single-motor requests in a log, in order.
fn host_commands(log: &[Logged]) -> Vec<(u8, Cmd)> {
    log.iter()
        .filter(|l| l.direction == FrameDirection::Tx)
        .filter_map(|l| match Dialect::V161.decode_request(&l.frame) {
            Ok(DecodedRequest::Single { motor, request }) => Some((motor.get(), request.command())),
            _ => None,
        })
        .collect()
}

/// What a command without `--protocol` sends `motor` first: the identifying reads (0x9A,
/// 0x9C), then `then`.
fn identified(motor: u8, then: &[Cmd]) -> Vec<(u8, Cmd)> {
    [Cmd::ReadStatus1, Cmd::ReadStatus2]
        .iter()
        .chain(then)
        .map(|&c| (motor, c))
        .collect()
}

#[test]
fn scan_lists_the_simulated_motors() {
    let out = ok(&["scan", "--sim"]);
    let ids: Vec<&str> = out
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(ids, ["1", "2", "3", "4"]);

    let out = ok(&["scan", "--sim", "--sim-ids", "2,5", "--json"]);
    let list = json_lines(&out).remove(0);
    let ids: Vec<u64> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, [2, 5]);
    assert_eq!(list[0]["voltage_volts"], 48.0);
    assert_eq!(list[0]["low_voltage"], false);

    // Nobody at the ids asked: an error that says what to check.
    let err = fails(1, &["scan", "--sim", "--ids", "10-12"]);
    assert!(err.contains("no motor answered"), "{err}");
    assert!(err.contains("ids 10-12"), "{err}");
}

#[test]
fn status_reads_everything_and_names_a_missing_motor() {
    let out = ok(&["status", "2", "--sim", "--json"]);
    let status = &json_lines(&out)[0];
    assert_eq!(status["id"], 2);
    for key in [
        "temperature_celsius",
        "voltage_volts",
        "iq_amps",
        "speed_dps",
        "i_a_amps",
        "encoder_raw",
        "encoder_offset",
        "motor_angle_degrees",
        "circle_angle_degrees",
    ] {
        assert!(status.get(key).is_some(), "{key} missing from {status}");
    }
    let human = ok(&["status", "1", "--sim"]);
    assert!(human.starts_with("motor 1\n"), "{human}");
    assert!(human.contains("voltage          48.0 V"), "{human}");

    // Motor 7 is not simulated: motor 1 is still read, motor 7's error names it and the fix.
    let out = rmd(&["status", "1,7", "--sim", "--json", "--timeout-ms", "5"]);
    assert_eq!(out.status.code(), Some(1));
    let lines = json_lines(&text(&out.stdout));
    assert_eq!(lines[0]["id"], 1);
    assert_eq!(lines[1]["id"], 7);
    let err = text(&out.stderr);
    assert!(
        err.contains("motor 7 did not answer read-status-1 within 5 ms (3 attempts)"),
        "{err}"
    );
    assert!(err.contains("--sim-ids"), "{err}");
}

#[test]
fn pid_set_changes_only_the_given_gains_in_ram() {
    let log = log_path("pid");
    let out = ok(&[
        "pid",
        "set",
        "3",
        "--speed-pid-kp",
        "61",
        "--sim",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert!(out.contains("written to RAM"), "{out}");
    assert!(out.contains("speed kp 61 ki 40"), "{out}");
    let recorded = read_log(&log);
    assert_eq!(
        host_commands(&recorded),
        identified(3, &[Cmd::ReadPid, Cmd::WritePidRam])
    );
    // Each request was answered by the motor (a reply follows it on the same id).
    let replies = recorded
        .iter()
        .filter(|l| l.direction == FrameDirection::Rx)
        .count();
    assert_eq!(replies, 4);

    let get = json_lines(&ok(&["pid", "get", "3", "--sim", "--json"])).remove(0);
    assert_eq!(get["id"], 3);
    assert_eq!(get["angle_pid_kp"], 100);
    assert!(fails(2, &["pid", "set", "3", "--sim"]).contains("give at least one gain"));
}

#[test]
fn rom_writes_need_a_confirmation_a_script_gives_with_yes() {
    let log = log_path("rom");
    let log_arg = log.to_str().unwrap();
    // stdin is not a terminal here: refused once the motor is identified, nothing written.
    let err = fails(
        1,
        &[
            "pid",
            "set",
            "1",
            "--iq-pid-ki",
            "9",
            "--rom",
            "--sim",
            "--log",
            log_arg,
        ],
    );
    assert!(err.contains("needs confirmation"), "{err}");
    assert!(err.contains("pass --yes"), "{err}");
    assert_eq!(host_commands(&read_log(&log)), identified(1, &[]));

    let out = ok(&[
        "pid",
        "set",
        "1",
        "--iq-pid-ki",
        "9",
        "--rom",
        "--yes",
        "--sim",
        "--log",
        log_arg,
    ]);
    assert!(out.contains("written to ROM"), "{out}");
    assert_eq!(
        host_commands(&read_log(&log)),
        identified(1, &[Cmd::ReadPid, Cmd::WritePidRom])
    );

    let err = fails(1, &["zero", "2", "--sim", "--log", log_arg]);
    assert!(
        err.contains("zero of motor 2") && err.contains("pass --yes"),
        "{err}"
    );
    let out = ok(&["zero", "2", "--sim", "--yes", "--log", log_arg]);
    assert!(out.contains("power-cycle the motor"), "{out}");
    assert_eq!(
        host_commands(&read_log(&log)),
        identified(2, &[Cmd::WriteZeroRom])
    );
}

#[test]
fn accel_and_encoder_commands() {
    let out = ok(&["accel", "set", "2", "1500", "--sim"]);
    assert_eq!(
        out,
        "motor 2: acceleration 1500 dps/s written to RAM (lost at power off)\n"
    );
    let accel = json_lines(&ok(&["accel", "get", "2", "--sim", "--json"])).remove(0);
    assert_eq!(accel["accel_dps_per_s"], 36000.0);

    let enc = json_lines(&ok(&["encoder", "get", "4", "--sim", "--json"])).remove(0);
    assert_eq!(enc["encoder_offset"], 0);
    assert_eq!(
        ok(&["encoder", "offset", "4", "1234", "--sim"]),
        "motor 4: encoder offset 1234 written\n"
    );
    assert_eq!(
        ok(&["encoder", "offset", "4", "--here", "--sim"]),
        "motor 4: encoder offset 0 written\n"
    );
    // LK-TECH firmware keeps the offset in ROM: asked first, as `rmd zero`.
    let lk = ["--protocol", "lk-v2.3x", "--lk-series", "mf"];
    let err = fails(
        1,
        &[&["encoder", "offset", "4", "99", "--sim"][..], &lk].concat(),
    );
    assert!(
        err.contains("encoder offset of motor 4 to ROM") && err.contains("pass --yes"),
        "{err}"
    );
    assert_eq!(
        ok(&[&["encoder", "offset", "4", "99", "--sim", "--yes"][..], &lk].concat()),
        "motor 4: encoder offset 99 written\n"
    );
    // Checked against the encoder width before anything is sent.
    let err = fails(2, &["encoder", "offset", "4", "20000", "--sim"]);
    assert!(err.contains("for a 14-bit encoder"), "{err}");
    ok(&[
        "encoder",
        "offset",
        "4",
        "20000",
        "--sim",
        "--encoder-bits",
        "16",
    ]);
}

#[test]
fn off_stop_run_each_motor() {
    let log = log_path("power");
    let log_arg = log.to_str().unwrap();
    assert_eq!(
        ok(&["off", "1-3", "--sim", "--log", log_arg]),
        "motor 1: off\nmotor 2: off\nmotor 3: off\n"
    );
    assert_eq!(
        host_commands(&read_log(&log)),
        [(1, Cmd::MotorOff), (2, Cmd::MotorOff), (3, Cmd::MotorOff)]
    );
    ok(&["stop", "2", "--sim"]);
    assert_eq!(ok(&["run", "2", "--sim"]), "motor 2: running\n");
    let err = fails(1, &["off", "4,6", "--sim", "--timeout-ms", "5"]);
    assert!(err.contains("motor 6 did not answer motor-off"), "{err}");
}

#[test]
fn move_reaches_the_target_within_limits() {
    let log = log_path("move");
    let log_arg = log.to_str().unwrap();
    let out = ok(&["move", "1", "--deg", "90", "--sim", "--log", log_arg]);
    assert!(out.starts_with("motor 1: at "), "{out}");
    assert!(out.contains("holding the position"), "{out}");
    let commands = host_commands(&read_log(&log));
    assert_eq!(commands[..3], identified(1, &[Cmd::Position2]));
    assert!(
        commands[3..]
            .iter()
            .all(|c| *c == (1, Cmd::ReadMultiTurnAngle))
    );
    // The motor is left holding: no motor-off.
    assert!(!commands.contains(&(1, Cmd::MotorOff)));

    // The four modes.
    ok(&["move", "1", "--deg", "-45", "--mode", "1", "--sim"]);
    ok(&[
        "move",
        "1",
        "--deg",
        "180",
        "--mode",
        "3",
        "--direction",
        "ccw",
        "--sim",
    ]);
    ok(&[
        "move",
        "1",
        "--deg",
        "270",
        "--mode",
        "4",
        "--max-speed",
        "720",
        "--sim",
    ]);

    // Limits and mode rules are checked before anything is sent.
    let err = fails(
        2,
        &[
            "move",
            "2",
            "--deg",
            "200",
            "--max-deg",
            "180",
            "--sim",
            "--log",
            log_arg,
        ],
    );
    assert!(
        err.contains("outside the limits") && err.contains("nothing was sent"),
        "{err}"
    );
    assert!(
        fails(2, &["move", "2", "--deg", "-10", "--min-deg", "0", "--sim"]).contains("motor 2")
    );
    assert!(
        fails(
            2,
            &[
                "move",
                "2",
                "--deg",
                "10",
                "--mode",
                "1",
                "--max-speed",
                "5",
                "--sim"
            ]
        )
        .contains("needs mode 2 or 4")
    );
    assert!(fails(2, &["move", "2", "--deg", "360", "--mode", "3", "--sim"]).contains("0..<360"));

    // Not there in time: the motor is turned off and the error says where it got to.
    let err = fails(
        1,
        &[
            "move",
            "3",
            "--deg",
            "3600",
            "--max-speed",
            "10",
            "--wait-timeout",
            "300ms",
            "--sim",
        ],
    );
    assert!(err.contains("motor 3 did not reach 3600°"), "{err}");
    assert!(err.contains("motor 3 turned off"), "{err}");
}

#[test]
fn torque_and_speed_run_for_their_duration_then_turn_the_motor_off() {
    let log = log_path("torque");
    let log_arg = log.to_str().unwrap();
    let out = ok(&[
        "torque",
        "2",
        "--amps",
        "0.5",
        "--duration",
        "200ms",
        "--rate",
        "50",
        "--sim",
        "--log",
        log_arg,
    ]);
    assert!(out.contains("then turned off"), "{out}");
    let commands = host_commands(&read_log(&log));
    let (last, drive) = commands.split_last().unwrap();
    assert_eq!(*last, (2, Cmd::MotorOff));
    assert_eq!(drive[..2], identified(2, &[]));
    assert!(drive.len() >= 4, "{commands:?}");
    assert!(drive[2..].iter().all(|c| *c == (2, Cmd::Torque)));

    let out = ok(&[
        "speed",
        "1",
        "--dps",
        "-360",
        "--duration",
        "200ms",
        "--sim",
        "--log",
        log_arg,
    ]);
    assert!(out.contains("speed -360.00 dps"), "{out}");
    let commands = host_commands(&read_log(&log));
    assert_eq!(commands.last(), Some(&(1, Cmd::MotorOff)));
    assert_eq!(commands[..3], identified(1, &[Cmd::Speed]));

    // A speed limit in torque mode: the unloaded motor speeds up past it and is turned off.
    let err = fails(
        1,
        &[
            "torque",
            "1",
            "--amps",
            "2",
            "--duration",
            "10s",
            "--max-speed",
            "200",
            "--sim",
            "--log",
            log_arg,
        ],
    );
    assert!(err.contains("above --max-speed 200"), "{err}");
    assert!(err.contains("motor 1 turned off"), "{err}");
    assert_eq!(
        host_commands(&read_log(&log)).last(),
        Some(&(1, Cmd::MotorOff))
    );
}

#[test]
fn drive_flags_take_the_examples_names_and_durations_with_units() {
    let log = log_path("drive-vocabulary");
    let log_arg = log.to_str().unwrap();
    // `--seconds` (bare seconds) and `--rate-hz` are `--duration` and `--rate`.
    let out = ok(&[
        "torque",
        "2",
        "--amps",
        "0.2",
        "--seconds",
        "0.2",
        "--rate-hz",
        "50",
        "--sim",
        "--log",
        log_arg,
    ]);
    // The run lasted the 0.2 s asked for (longer on a loaded machine: the time is measured).
    let lasted: f64 = out
        .split(" for ")
        .nth(1)
        .and_then(|rest| rest.split(" s (").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    assert!(lasted >= 0.195, "{out}");
    let commands = host_commands(&read_log(&log));
    assert_eq!(commands.last(), Some(&(2, Cmd::MotorOff)));
    // Durations that are not one are usage errors before anything is sent.
    for bad in ["inf", "nan", "-1", "2 fortnights"] {
        let err = fails(
            2,
            &["torque", "2", "--amps", "0.2", "--duration", bad, "--sim"],
        );
        assert!(err.contains("--duration"), "{bad}: {err}");
        assert!(!err.contains("panicked"), "{bad}: {err}");
        let err = fails(
            2,
            &["move", "2", "--deg", "10", "--wait-timeout", bad, "--sim"],
        );
        assert!(err.contains("--wait-timeout"), "{bad}: {err}");
    }
}

/// Waits for a child to exit, at most `limit` (a hang is a failure, not a timing goal).
fn wait_exit(child: &mut Child, limit: Duration) -> i32 {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status.code().expect("exited normally");
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("the command did not end after Ctrl-C");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Starts `rmd ARGS`, waits until its stderr says `ready`, sends SIGINT, and returns the exit
/// status and the rest of stderr.
fn interrupt_when(args: &[&str], ready: &str) -> (i32, String) {
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("rmd"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        assert!(
            stderr.read_line(&mut line).unwrap() > 0,
            "rmd ended before `{ready}`: {seen}"
        );
        seen.push_str(&line);
        if line.contains(ready) {
            break;
        }
    }
    let kill = StdCommand::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let code = wait_exit(&mut child, Duration::from_secs(30));
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    (code, rest)
}

#[test]
fn ctrl_c_turns_a_moving_motor_off() {
    let log = log_path("ctrl-c");
    let log_arg = log.to_str().unwrap();
    for args in [
        &["speed", "3", "--dps", "720", "--duration", "60s"][..],
        &["torque", "3", "--amps", "0.3", "--duration", "60s"][..],
    ] {
        let mut args = args.to_vec();
        args.extend(["--sim", "--log", log_arg]);
        let (code, stderr) = interrupt_when(&args, "Ctrl-C stops it");
        assert_eq!(code, 130, "{stderr}");
        assert!(stderr.contains("interrupted:"), "{stderr}");
        assert!(stderr.contains("motor 3 turned off"), "{stderr}");
        let recorded = read_log(&log);
        assert_eq!(
            host_commands(&recorded).last(),
            Some(&(3, Cmd::MotorOff)),
            "{args:?}"
        );
        // ... and the motor confirmed it.
        let last = recorded.last().unwrap();
        assert_eq!(last.direction, FrameDirection::Rx);
        assert_eq!(last.frame.data()[0], Cmd::MotorOff.code());
    }
}

#[test]
fn ctrl_c_during_a_move_turns_the_motor_off() {
    let log = log_path("ctrl-c-move");
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("rmd"))
        .args([
            "move",
            "1",
            "--deg",
            "3600",
            "--max-speed",
            "10",
            "--sim",
            "--log",
            log.to_str().unwrap(),
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The move has started once the log shows the position command's reply.
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
    StdCommand::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert_eq!(wait_exit(&mut child, Duration::from_secs(30)), 130);
    assert_eq!(
        host_commands(&read_log(&log)).last(),
        Some(&(1, Cmd::MotorOff))
    );
}

#[test]
fn monitor_prints_readings_as_json_lines() {
    let out = ok(&["monitor", "--sim", "--count", "3", "--rate", "50", "--json"]);
    let readings = json_lines(&out);
    assert_eq!(readings.len(), 3);
    for reading in &readings {
        let motors = reading["motors"].as_array().unwrap();
        let ids: Vec<u64> = motors.iter().map(|m| m["id"].as_u64().unwrap()).collect();
        assert_eq!(ids, [1, 2, 3, 4]);
        assert!(motors[0].get("motor_angle_degrees").is_some());
        assert!(motors[0].get("iq_amps").is_some());
    }
    assert!(readings[2]["time_s"].as_f64() > readings[0]["time_s"].as_f64());
    // A table when not asked for JSON; a motor that does not answer is a row, not the end.
    let out = ok(&[
        "monitor",
        "--sim",
        "--ids",
        "2,9",
        "--count",
        "1",
        "--timeout-ms",
        "5",
    ]);
    assert!(
        out.lines()
            .any(|l| l.trim_start().starts_with("9 ") && l.ends_with("no reply")),
        "{out}"
    );
    assert!(
        out.lines().any(|l| l.trim_start().starts_with("2 ")),
        "{out}"
    );
}

/// Each motor's multi-turn angle, motor degrees, in every reading of `rmd monitor --json`.
fn monitor_angles(readings: &[Value]) -> Vec<Vec<f64>> {
    let motors = readings[0]["motors"].as_array().unwrap().len();
    (0..motors)
        .map(|m| {
            readings
                .iter()
                .map(|r| r["motors"][m]["motor_angle_degrees"].as_f64().unwrap())
                .collect()
        })
        .collect()
}

#[test]
fn monitor_demo_moves_the_simulated_motors() {
    let spread = |angles: &[f64]| {
        let max = angles.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = angles.iter().copied().fold(f64::INFINITY, f64::min);
        max - min
    };
    // Without --demo nothing moves.
    let still = json_lines(&ok(&[
        "monitor", "--sim", "--count", "6", "--rate", "10", "--json",
    ]));
    for angles in monitor_angles(&still) {
        assert_eq!(spread(&angles), 0.0, "{angles:?}");
    }
    // With it, every motor turns (the JSON objects are the same as without).
    let moving = json_lines(&ok(&[
        "monitor", "--sim", "--demo", "--count", "8", "--rate", "10", "--json",
    ]));
    assert_eq!(moving.len(), 8);
    let angles = monitor_angles(&moving);
    assert_eq!(angles.len(), 4);
    for (motor, angles) in angles.iter().enumerate() {
        assert!(spread(angles) > 0.5, "motor {}: {angles:?}", motor + 1);
        assert!(
            angles.iter().all(|a| a.abs() < 100.0),
            "a gentle motion: {angles:?}"
        );
    }
    assert_eq!(
        moving[0]["motors"][0]
            .as_object()
            .unwrap()
            .keys()
            .collect::<Vec<_>>(),
        still[0]["motors"][0]
            .as_object()
            .unwrap()
            .keys()
            .collect::<Vec<_>>()
    );
    // Not on a terminal: the table, its angles no longer all zero.
    let table = ok(&["monitor", "--sim", "--demo", "--count", "6", "--rate", "10"]);
    let last: Vec<&str> = table
        .lines()
        .rev()
        .filter(|l| !l.is_empty())
        .take(4)
        .collect();
    assert!(
        last.iter().any(|row| {
            let angle = row.split_whitespace().nth(5).unwrap();
            angle.parse::<f64>().unwrap() != 0.0
        }),
        "{table}"
    );
    // --demo only drives simulated motors.
    let refused = fails(2, &["monitor", "--demo", "--ids", "1"]);
    assert!(refused.contains("--sim"), "{refused}");
}

/// What a 100x40 terminal shows after `bytes` (the alternate screen while it is on).
fn screen_after(bytes: &[u8]) -> String {
    let mut terminal = vt100::Parser::new(40, 100, 0);
    terminal.process(bytes);
    terminal.screen().contents()
}

/// `rmd monitor --sim --demo ARGS` on a pseudo-terminal of 100x40 (util-linux `script`); `keys`
/// are typed once the first plot is on the screen (and the pipe held open after them). Returns
/// everything the terminal received, once the monitor ended (at most 60 s).
fn monitor_on_a_terminal(args: &str, keys: &[u8]) -> String {
    use std::io::Write;
    let command = format!(
        "stty cols 100 rows 40; exec '{}' monitor --sim --demo {args}",
        env!("CARGO_BIN_EXE_rmd")
    );
    let mut child = StdCommand::new("script")
        .args(["-qec", &command, "/dev/null"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("util-linux `script` runs (package bsdutils)");
    let mut stdout = child.stdout.take().unwrap();
    let (sender, received) = std::sync::mpsc::channel::<Vec<u8>>();
    std::thread::spawn(move || {
        let mut buffer = [0_u8; 4096];
        while let Ok(n) = stdout.read(&mut buffer) {
            if n == 0 || sender.send(buffer[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut screen = Vec::new();
    let mut typed = keys.is_empty();
    let mut stdin = child.stdin.take();
    loop {
        match received.recv_timeout(Duration::from_millis(100)) {
            Ok(bytes) => screen.extend_from_slice(&bytes),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
        }
        if !typed && screen_after(&screen).contains("motor 4: angle °  last") {
            stdin.as_mut().unwrap().write_all(keys).unwrap();
            stdin.as_mut().unwrap().flush().unwrap();
            typed = true;
        }
        if Instant::now() > deadline {
            child.kill().unwrap();
            panic!("the monitor did not end: {}", text(&screen));
        }
    }
    assert!(child.wait().unwrap().success(), "{}", text(&screen));
    drop(stdin);
    text(&screen)
}

/// Checks the live view was drawn, then the terminal restored and the last table printed.
fn assert_drawn_and_restored(screen: &str, signal: &str) {
    let entered = screen.find("\x1b[?1049h").expect("the alternate screen");
    let left = screen
        .rfind("\x1b[?1049l")
        .expect("back to the normal screen");
    assert!(entered < left, "{screen:?}");
    let live = screen_after(&screen.as_bytes()[..left]);
    for title in [
        &format!("motor 1: {signal}  last"),
        &format!("motor 4: {signal}  last"),
        &format!("plotting: {signal}"),
        "q quit",
    ] {
        assert!(live.contains(title), "{title}: {live:?}");
    }
    // Raw mode ended (the pseudo-terminal translates newlines again), the cursor shown, then
    // the last reading's table.
    let after = &screen[left..];
    assert!(after.contains("\x1b[?25h"), "{after:?}");
    assert!(
        after.contains(" id  temp °C  volts    iq A  speed dps     angle °  errors\r\n"),
        "{after:?}"
    );
}

#[test]
fn monitor_on_a_terminal_plots_and_restores_the_terminal_on_every_exit() {
    // --count: the end of the readings.
    let screen = monitor_on_a_terminal("--count 5 --rate 10", b"");
    assert_drawn_and_restored(&screen, "angle °");
    // `q`, and Ctrl-C (a key in raw mode), end a monitor that would run for ever.
    assert_drawn_and_restored(&monitor_on_a_terminal("--rate 20", b"q"), "angle °");
    assert_drawn_and_restored(&monitor_on_a_terminal("--rate 20", b"\x03"), "angle °");
    // Keys switch the signal (the plots' titles follow).
    let switched = monitor_on_a_terminal("--rate 20", b"c\tq");
    assert_drawn_and_restored(&switched, "temperature °C");
    let left = switched.rfind("\x1b[?1049l").unwrap();
    let live = screen_after(&switched.as_bytes()[..left]);
    assert!(live.contains("plotting: temperature °C"), "{live}");
    assert!(
        live.contains("motor 1: temperature °C  last 25.00  min 25.00  max 25.00"),
        "{live}"
    );
}

#[test]
fn a_recorded_session_decodes_and_replays() {
    let log = log_path("session");
    let log_arg = log.to_str().unwrap();
    // Named, the protocol is checked with one read of status 1; then the six reads. (Without
    // --protocol the two identifying reads go out together, both before either reply.)
    ok(&[
        "status",
        "1",
        "--sim",
        "--protocol",
        "v1.61",
        "--log",
        log_arg,
    ]);
    let recorded = read_log(&log);
    // Seven reads, each request followed by its reply.
    assert_eq!(recorded.len(), 14);

    let decoded = json_lines(&ok(&["decode", log_arg]));
    assert_eq!(decoded.len(), 14);
    for pair in decoded.chunks(2) {
        assert_eq!(pair[0]["direction"], "request");
        assert_eq!(pair[1]["direction"], "reply");
        assert_eq!(pair[0]["command"], pair[1]["command"]);
        assert_eq!(pair[0]["interface"], "sim");
    }
    assert_eq!(decoded[1]["voltage_volts"], 48.0);

    // Printed back as it was (every frame, in order).
    let printed = ok(&["replay", log_arg, "--fast"]);
    let original = std::fs::read_to_string(&log).unwrap();
    assert_eq!(printed, original);

    // The host's frames of a scan sent again to simulated motors, which answer them again.
    // (Two requests per motor: a longer burst of requests to one motor, as a stalled replay
    // would send, can overflow its three transmit mailboxes, as on a real motor.)
    let scan = log_path("scan-session");
    let scan_arg = scan.to_str().unwrap();
    ok(&["scan", "--sim", "--ids", "1-4", "--log", scan_arg]);
    let out = rmd(&["replay", scan_arg, "--sim"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let session: Vec<_> = text(&out.stdout)
        .lines()
        .map(|l| parse_line(l).unwrap())
        .collect();
    let sent: Vec<u16> = session
        .iter()
        .filter(|l| l.direction == Some(FrameDirection::Tx))
        .map(|l| l.frame.id())
        .collect();
    let replies: Vec<(u8, Reply)> = session
        .iter()
        .filter(|l| l.direction == Some(FrameDirection::Rx))
        .map(|l| {
            let (motor, reply) = rmd_protocol::Dialect::V161.decode_reply(&l.frame).unwrap();
            (motor.get(), reply)
        })
        .collect();
    // The scan's two probes per motor: 0x9A and 0x9C.
    assert_eq!(
        sent,
        [0x141, 0x141, 0x142, 0x142, 0x143, 0x143, 0x144, 0x144]
    );
    assert_eq!(replies.len(), 8);
    for (i, (motor, reply)) in replies.iter().enumerate() {
        assert_eq!(usize::from(*motor), i / 2 + 1);
        let probe = [Cmd::ReadStatus1, Cmd::ReadStatus2][i % 2];
        assert_eq!(reply.command(), probe);
    }
    assert!(text(&out.stderr).contains("replayed 8 frame(s) onto the simulated bus"));
}

#[test]
fn replay_skips_and_reports_bad_lines() {
    let log = log_path("bad-lines");
    std::fs::write(
        &log,
        "(1.000000) can0 141#9C00000000000000\nnot a frame\n(1.000100) can0 141#9C19000000000000\n",
    )
    .unwrap();
    let out = rmd(&["replay", log.to_str().unwrap(), "--fast"]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(text(&out.stdout).lines().count(), 2);
    assert!(
        text(&out.stderr).contains("line 2"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn replaying_motion_onto_a_real_interface_asks_first() {
    let log = log_path("replay-motion");
    std::fs::write(
        &log,
        "(1.000000) can0 141#A100000064000000 T\n(1.000300) can0 141#A119000000000000 R\n",
    )
    .unwrap();
    let file = log.to_str().unwrap();
    // can7: a real adapter's name; no terminal here and no --yes: refused before opening it.
    let err = fails(1, &["replay", file, "--iface", "can7"]);
    assert!(
        err.contains("replaying motion commands onto can7 needs confirmation"),
        "{err}"
    );
    // Confirmed, it goes on to open the interface (missing here).
    let err = fails(1, &["replay", file, "--iface", "can7", "--yes"]);
    assert!(err.contains("`can7` does not exist"), "{err}");
    // Onto simulated motors no confirmation is needed, and the motor is turned off at the end.
    let session = log_path("replay-motion-session");
    let out = rmd(&["replay", file, "--sim", "--log", session.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let sent: Vec<_> = stdout
        .lines()
        .map(|l| parse_line(l).unwrap())
        .filter(|l| l.direction == Some(FrameDirection::Tx))
        .map(|l| l.frame.data()[0])
        .collect();
    assert_eq!(sent, [Cmd::Torque.code()]);
    assert!(text(&out.stderr).contains("replayed 1 frame(s)"));
    assert_eq!(
        host_commands(&read_log(&session)),
        [(1, Cmd::Torque), (1, Cmd::MotorOff)]
    );
}

#[test]
fn bus_errors_say_what_to_do() {
    let err = fails(2, &["status", "1"]);
    assert!(err.contains("use --iface IFACE"), "{err}");
    let err = fails(1, &["scan", "--iface", "rmdnope9"]);
    assert!(
        err.contains("rmdnope9") && err.contains("does not exist"),
        "{err}"
    );
    let err = fails(1, &["status", "1", "--iface", "lo"]);
    assert!(err.contains("not a CAN interface"), "{err}");
    let err = fails(1, &["log", "--iface", "vcan97", "/dev/null"]);
    assert!(err.contains("ip link add dev vcan97 type vcan"), "{err}");
    let err = fails(1, &["sim", "--iface", "vcan97"]);
    assert!(err.contains("ip link add dev vcan97 type vcan"), "{err}");
    fails(2, &["status", "1", "--iface", "can0", "--sim"]);
    fails(2, &["sim", "--iface", "vcan0", "--drop", "1.5"]);
}

/// The leg of the examples, as its description file.
fn leg_robot() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/robots/leg4.toml")
        .display()
        .to_string()
}

/// The stable interface: `rmd status --robot FILE --sim --json` prints one object per motor,
/// each carrying its joint `name` from the file (with its bus and joint units).
#[test]
fn status_of_a_robot_speaks_joint_names_and_joint_units() {
    let robot = leg_robot();
    let objects = json_lines(&ok(&["status", "--robot", &robot, "--sim", "--json"]));
    let names: Vec<&str> = objects
        .iter()
        .map(|o| o["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["hip_aa", "hip_fe", "knee", "ankle"]);
    for (o, id) in objects.iter().zip(1..) {
        assert_eq!(o["id"], id);
        assert_eq!(o["bus"], "leg");
        // Joint units: the motor's multi-turn angle through the description's mapping
        // (joint = motor / gear - zero offset); velocity and torque from status 2.
        let motor_deg = o["motor_angle_degrees"].as_f64().unwrap();
        let joint_deg = o["joint"]["angle_deg"].as_f64().unwrap();
        let offset = [20.0, 50.0, -40.0, 50.0][id as usize - 1];
        assert!((joint_deg - (motor_deg / 9.0 - offset)).abs() < 1e-9, "{o}");
        // The simulated joints power up in the middle of their power-up windows (40 degrees
        // wide from -offset), where the description reads them right.
        assert!((joint_deg - (20.0 - offset)).abs() < 0.05, "{o}");
        assert!(o["joint"]["velocity_dps"].is_f64(), "{o}");
        assert!(o["joint"]["torque_nm"].is_f64(), "{o}");
    }
    // One joint by name, in words.
    let knee = ok(&["status", "--robot", &robot, "--sim", "knee"]);
    assert!(knee.starts_with("knee (motor 3 on bus leg)"), "{knee}");
    assert!(knee.contains("joint angle"), "{knee}");
    // A joint the robot does not have: a usage error listing the ones it has.
    let err = fails(2, &["status", "--robot", &robot, "--sim", "elbow"]);
    assert!(err.contains("hip_aa, hip_fe, knee, ankle"), "{err}");
}

/// `rmd off|stop|run --robot FILE [JOINTS]`: the joints by name (all without names), each sent
/// its command on its bus and confirmed.
#[test]
fn off_stop_run_take_joint_names() {
    let robot = leg_robot();
    let log = log_path("off-joints");
    let log_arg = log.to_str().unwrap();
    assert_eq!(
        ok(&[
            "off", "--robot", &robot, "--sim", "knee", "ankle", "--log", log_arg
        ]),
        "knee (motor 3 on bus leg): off\nankle (motor 4 on bus leg): off\n"
    );
    assert_eq!(
        host_commands(&read_log(&log)),
        [(3, Cmd::MotorOff), (4, Cmd::MotorOff)]
    );
    let every = ok(&["off", "--robot", &robot, "--sim"]);
    assert_eq!(every.lines().count(), 4, "{every}");
    for name in ["hip_aa", "hip_fe", "knee", "ankle"] {
        assert!(every.contains(&format!("{name} (motor")), "{every}");
    }
    assert_eq!(
        ok(&["stop", "--robot", &robot, "--sim", "hip_fe"]),
        "hip_fe (motor 2 on bus leg): stopped (run resumes it)\n"
    );
    assert_eq!(
        ok(&["run", "--robot", &robot, "--sim", "hip_fe,knee"]),
        "hip_fe (motor 2 on bus leg): running\nknee (motor 3 on bus leg): running\n"
    );
    // A name the file does not have is a usage error that lists the names it has.
    let err = fails(2, &["off", "--robot", &robot, "--sim", "elbow"]);
    assert!(err.contains("hip_aa, hip_fe, knee, ankle"), "{err}");
    // Without --robot the targets are motor ids, and there must be some.
    let err = fails(2, &["off", "--sim"]);
    assert!(err.contains("which motors?"), "{err}");
}

/// A command that takes motor ids refuses --robot instead of ignoring it (and talking to
/// whatever --iface/--sim say, the description unread).
#[test]
fn commands_without_joint_names_refuse_a_robot() {
    let robot = leg_robot();
    for args in [
        &["scan", "--robot", &robot, "--sim"][..],
        &["pid", "get", "1", "--robot", &robot, "--sim"],
        &["torque", "1", "--amps", "0.1", "--robot", &robot, "--sim"],
    ] {
        let err = fails(2, args);
        assert!(
            err.contains("takes motor ids, not a robot's joints"),
            "{err}"
        );
    }
}

#[test]
fn move_by_joint_name_in_joint_degrees_and_monitor_by_joint() {
    let robot = leg_robot();
    let log = log_path("move-joint");
    let out = ok(&[
        "move",
        "--robot",
        &robot,
        "--sim",
        "knee",
        "--deg",
        "45",
        "--wait-timeout",
        "5s",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert!(out.starts_with("knee: at "), "{out}");
    // The motor was sent the joint's target turned into motor degrees: (45 + (-40)) * 9 = 45.
    let sent: Vec<_> = read_log(&log)
        .into_iter()
        .filter(|l| l.direction == FrameDirection::Tx)
        .filter_map(|l| match Dialect::V161.decode_request(&l.frame) {
            Ok(DecodedRequest::Single {
                motor,
                request:
                    rmd_protocol::Request::Position2 {
                        angle_control,
                        max_speed,
                    },
            }) => Some((motor.get(), angle_control.degrees(), max_speed.dps())),
            _ => None,
        })
        .collect();
    // Without --max-speed, 360 dps at the motor, as without --robot.
    assert_eq!(sent, [(3, 45.0, 360.0)]);
    // Simulated motors end with the command: no `rmd off` to run afterwards (a later `rmd
    // off --sim` would talk to new motors).
    assert!(!out.contains("rmd off"), "{out}");
    assert!(out.contains("nothing is left to release"), "{out}");
    // With it, joint degrees per second: 10 at the joint is 90 at the motor.
    let log = log_path("move-joint-speed");
    ok(&[
        "move",
        "--robot",
        &robot,
        "--sim",
        "knee",
        "--deg",
        "42",
        "--max-speed",
        "10",
        "--wait-timeout",
        "10s",
        "--log",
        log.to_str().unwrap(),
    ]);
    let speeds: Vec<f64> = read_log(&log)
        .into_iter()
        .filter(|l| l.direction == FrameDirection::Tx)
        .filter_map(|l| match Dialect::V161.decode_request(&l.frame) {
            Ok(DecodedRequest::Single {
                request: rmd_protocol::Request::Position2 { max_speed, .. },
                ..
            }) => Some(max_speed.dps()),
            _ => None,
        })
        .collect();
    assert_eq!(speeds, [90.0]);
    // Single-turn modes have no joint meaning.
    let err = fails(
        2,
        &[
            "move", "--robot", &robot, "--sim", "knee", "--deg", "45", "--mode", "3",
        ],
    );
    assert!(err.contains("mode 1 or 2"), "{err}");
    // The monitor labels the rows with joint names and shows joint degrees.
    let table = ok(&["monitor", "--robot", &robot, "--sim", "--count", "1"]);
    assert!(table.contains("joint °"), "{table}");
    for name in ["hip_aa", "hip_fe", "knee", "ankle"] {
        assert!(table.contains(name), "{table}");
    }
    let objects = json_lines(&ok(&[
        "monitor", "--robot", &robot, "--sim", "--count", "1", "--ids", "knee", "--json",
    ]));
    assert_eq!(objects[0]["motors"][0]["name"], "knee");
}

/// `rmd watchdog --robot FILE` writes each motor's described watchdog (the V3 leg: 50 ms on
/// all four, over two buses), after one question; a robot without `watchdog_ms` is refused.
#[test]
fn the_watchdogs_of_a_robot_are_written_as_described_after_one_question() {
    let v3 = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/robots/leg4-v3.toml")
        .display()
        .to_string();
    let out = rmd(&["watchdog", "--robot", &v3, "--sim", "--yes"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    for (joint, id, bus) in [
        ("hip_aa", 1, "hip"),
        ("hip_fe", 2, "hip"),
        ("knee", 3, "foot"),
        ("ankle", 4, "foot"),
    ] {
        let said = format!(
            "{joint} (motor {id} on bus {bus}): communication watchdog 50 ms written to ROM"
        );
        assert!(stdout.contains(&said), "{said}\n{stdout}");
    }
    // Without --yes and without a terminal: nothing is written.
    let out = rmd(&["watchdog", "--robot", &v3, "--sim"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("needs confirmation"));
    assert!(!text(&out.stdout).contains("written to ROM"));
    // The v1.61 leg describes none.
    let out = rmd(&["watchdog", "--robot", &leg_robot(), "--sim", "--yes"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("no motor sets `watchdog_ms`"),
        "{}",
        text(&out.stderr)
    );
    // An id and a time with --robot: one or the other.
    let out = rmd(&["watchdog", "1", "50ms", "--robot", &v3, "--sim", "--yes"]);
    assert_eq!(out.status.code(), Some(2));
}
