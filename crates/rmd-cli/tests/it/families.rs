//! Every live command against every family the simulator runs (`--sim --sim-firmware`): v1.61,
//! LK-TECH V2.3x MF and MG, MyActuator V3. For each command and family, the frames the command
//! sent (its `--log` recording) are decoded in that family's own dialect, so a frame of another
//! family, or scaled for one, fails the test: each command either works with the family's
//! scales, or refuses before sending anything but the read-only identification, naming the
//! family and what to use instead. No assertion depends on timing.

use std::path::PathBuf;

use rmd_bus::candump::{FrameDirection, parse_line};
use rmd_protocol::{
    CanFrame, Command as Cmd, DecodedRequest, Dialect, FirmwareDate, LkSeries, Request, V3Firmware,
};

use crate::support;
use support::{rmd, text};

/// A family the simulator runs: the options that choose it, and its dialect.
struct Family {
    name: &'static str,
    sim: &'static [&'static str],
    dialect: Dialect,
}

/// The simulated V3 motor's firmware date (rmd-sim's default, from real X4 motors).
const SIM_V3_DATE: u32 = 2_025_070_202;

fn families() -> [Family; 4] {
    [
        Family {
            name: "v1.61",
            sim: &["--sim-firmware", "v1.61"],
            dialect: Dialect::V161,
        },
        Family {
            name: "lk-v2.3x mf",
            sim: &["--sim-firmware", "lk-v2.3x", "--lk-series", "mf"],
            dialect: Dialect::LkV23x(LkSeries::Mf),
        },
        Family {
            name: "lk-v2.3x mg",
            sim: &["--sim-firmware", "lk-v2.3x", "--lk-series", "mg"],
            dialect: Dialect::LkV23x(LkSeries::Mg),
        },
        Family {
            name: "myactuator-v3",
            sim: &["--sim-firmware", "myactuator-v3"],
            dialect: Dialect::MyActuatorV3(V3Firmware::dated(FirmwareDate::from_raw(SIM_V3_DATE))),
        },
    ]
}

impl Family {
    fn is_v3(&self) -> bool {
        matches!(self.dialect, Dialect::MyActuatorV3(_))
    }

    /// What identifying motor 1 sends: 0x9A, 0x9C; a V3 motor is then asked 0xB5 and 0xB2.
    fn identification(&self) -> Vec<Cmd> {
        let mut sent = vec![Cmd::ReadStatus1, Cmd::ReadStatus2];
        if self.is_v3() {
            sent.extend([Cmd::ReadModel, Cmd::ReadFirmwareDate]);
        }
        sent
    }

    /// What readying motor 1 to move sends after its identification: V3 reads status 1 (the
    /// brake; the simulated motor has none, so it is not released).
    fn ready_to_move(&self) -> Vec<Cmd> {
        let mut sent = self.identification();
        if self.is_v3() {
            sent.push(Cmd::ReadStatus1);
        }
        sent
    }

    /// What turning motor 1 off sends: 0x80, and on V3 the brake lock.
    fn off(&self) -> Vec<Cmd> {
        let mut sent = vec![Cmd::MotorOff];
        if self.is_v3() {
            sent.push(Cmd::BrakeLock);
        }
        sent
    }
}

/// A run of `rmd` on a family: its exit status, stdout, stderr and the requests it sent, each
/// decoded in the family's dialect.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    sent: Vec<Request>,
}

impl Run {
    fn commands(&self) -> Vec<Cmd> {
        self.sent.iter().map(Request::command).collect()
    }

    fn ok(&self) -> &Self {
        assert_eq!(self.code, Some(0), "{}\n{}", self.stdout, self.stderr);
        self
    }

    fn failed(&self) -> &Self {
        assert_eq!(self.code, Some(1), "{}\n{}", self.stdout, self.stderr);
        self
    }
}

/// A fresh log path per test and family.
fn log_path(test: &str, family: &Family) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "rmd-families-{}-{test}-{}",
        std::process::id(),
        family.name.replace(' ', "-")
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bus.log");
    let _ = std::fs::remove_file(&path);
    path
}

/// The host's frames of a log, decoded as requests of `dialect`: a frame that is not one of
/// the family's requests fails the test.
fn sent_in(log: &PathBuf, dialect: Dialect) -> Vec<Request> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines()
        .map(|line| parse_line(line).unwrap())
        .filter(|l| l.direction == Some(FrameDirection::Tx))
        .map(|l| match dialect.decode_request(&l.frame) {
            Ok(DecodedRequest::Single { motor, request }) => {
                assert_eq!(motor.get(), 1, "{}", l.frame);
                request
            }
            other => panic!(
                "{} is not a {dialect} request to motor 1: {other:?}",
                l.frame
            ),
        })
        .collect()
}

/// Runs `rmd COMMAND --sim --sim-ids 1 FAMILY-OPTIONS --log LOG`.
fn rmd_on(test: &str, family: &Family, command: &[&str]) -> Run {
    let log = log_path(test, family);
    let mut args = command.to_vec();
    args.extend(["--sim", "--sim-ids", "1"]);
    args.extend(family.sim);
    args.extend(["--log", log.to_str().unwrap()]);
    let out = rmd(&args);
    Run {
        code: out.status.code(),
        stdout: text(&out.stdout),
        stderr: text(&out.stderr),
        sent: sent_in(&log, family.dialect),
    }
}

/// Asserts a refusal: exit 1, only the identification sent, the message naming the family and
/// `instead`.
fn assert_refused(run: &Run, family: &Family, command: Cmd, instead: &str) {
    run.failed();
    assert_eq!(run.commands(), family.identification(), "{}", family.name);
    let said = format!("motor 1 speaks {}, which has no {command}", family.dialect);
    assert!(
        run.stderr.contains(&said),
        "{}: {}",
        family.name,
        run.stderr
    );
    assert!(
        run.stderr.contains(instead),
        "{}: {}",
        family.name,
        run.stderr
    );
    assert!(
        run.stderr.contains(&format!("{command} was not sent")),
        "{}",
        run.stderr
    );
}

#[test]
fn torque_sends_the_asked_current_in_each_familys_scale() {
    // 2 A: 125 in v1.61 (32 A per 2000), 248 in MF (16.5 A per 2048), 124 in MG (33 A per
    // 2048), 200 in V3 (0.01 A).
    for (family, raw) in families().iter().zip([125, 248, 124, 200]) {
        let run = rmd_on(
            "torque",
            family,
            &["torque", "1", "--amps", "2", "--duration", "100ms"],
        );
        run.ok();
        let mut expected = family.ready_to_move();
        let drive = run.commands().len() - expected.len() - family.off().len();
        assert!(drive >= 1, "{}: {:?}", family.name, run.commands());
        expected.extend(std::iter::repeat_n(Cmd::Torque, drive));
        expected.extend(family.off());
        assert_eq!(run.commands(), expected, "{}", family.name);
        for request in &run.sent {
            if let Request::Torque { iq_control } = request {
                assert_eq!(iq_control.raw(), raw, "{}", family.name);
                assert_eq!(iq_control.scale(), family.dialect.iq_control_scale());
                assert!((iq_control.amps() - 2.0).abs() <= iq_control.scale().amps_per_lsb() / 2.0);
            }
        }
        assert!(run.stdout.contains("then turned off"), "{}", run.stdout);
    }
    // Named, V3 is checked with status 1 and asked its firmware date, then driven the same.
    let v3_named = Family {
        name: "myactuator-v3 named",
        sim: &[
            "--sim-firmware",
            "myactuator-v3",
            "--protocol",
            "myactuator-v3",
        ],
        dialect: families()[3].dialect,
    };
    let run = rmd_on(
        "torque-named",
        &v3_named,
        &["torque", "1", "--amps", "2", "--duration", "100ms"],
    );
    run.ok();
    let commands = run.commands();
    assert_eq!(
        commands[..3],
        [Cmd::ReadStatus1, Cmd::ReadFirmwareDate, Cmd::ReadStatus1]
    );
    assert!(commands.ends_with(&[Cmd::MotorOff, Cmd::BrakeLock]));
    assert!(
        run.sent[3..run.sent.len() - 2]
            .iter()
            .all(|r| matches!(r, Request::Torque { iq_control } if iq_control.raw() == 200))
    );
    // --iq-control is the family's raw value: 100 is 1 A on V3.
    let v3 = &families()[3];
    let run = rmd_on(
        "torque-raw",
        v3,
        &["torque", "1", "--iq-control", "100", "--duration", "100ms"],
    );
    run.ok();
    assert!(run.stdout.contains("torque 1.000 A"), "{}", run.stdout);
    // Beyond the family's range: refused once the family is known, nothing else sent.
    let mf = &families()[1];
    let run = rmd_on("torque-range", mf, &["torque", "1", "--amps", "20"]);
    run.failed();
    assert_eq!(run.commands(), mf.identification());
    assert!(
        run.stderr
            .contains("cannot send torque to motor 1 in protocol lk-v2.3x (MF)"),
        "{}",
        run.stderr
    );
}

#[test]
fn an_lk_motor_of_unknown_series_is_not_driven() {
    let lk = Family {
        name: "lk-v2.3x",
        sim: &["--sim-firmware", "lk-v2.3x"],
        dialect: Dialect::LkV23x(LkSeries::Mg),
    };
    for command in [
        &["torque", "1", "--amps", "1"][..],
        &["speed", "1", "--dps", "10"],
        &["move", "1", "--deg", "10"],
        // Their replies carry a current too: status reads status 1, then refuses 0x9C.
        &["status", "1"],
        &["monitor", "--ids", "1", "--count", "1"],
    ] {
        let run = rmd_on("lk-no-series", &lk, command);
        run.failed();
        let mut expected = lk.identification();
        if command[0] != "torque" && command[0] != "speed" && command[0] != "move" {
            expected.push(Cmd::ReadStatus1);
        }
        assert_eq!(run.commands(), expected, "{command:?}");
        assert!(run.stderr.contains("add --lk-series mf"), "{}", run.stderr);
    }
    // Off needs no series.
    rmd_on("lk-no-series-off", &lk, &["off", "1"]).ok();
}

#[test]
fn speed_sends_centidegrees_per_second_in_every_family() {
    for family in &families() {
        let run = rmd_on(
            "speed",
            family,
            &["speed", "1", "--dps", "90", "--duration", "100ms"],
        );
        run.ok();
        let commands = run.commands();
        let ready = family.ready_to_move();
        assert_eq!(commands[..ready.len()], ready[..], "{}", family.name);
        assert!(commands.ends_with(&family.off()), "{}", family.name);
        for request in &run.sent[ready.len()..run.sent.len() - family.off().len()] {
            let Request::Speed {
                speed_control,
                max_torque,
            } = request
            else {
                panic!("{}: {request:?}", family.name);
            };
            assert_eq!(speed_control.raw(), 9000);
            assert!(!max_torque.is_set());
        }
        // V3 speeds are the output shaft's.
        assert_eq!(
            run.stdout.contains("90.00 dps at the output"),
            family.is_v3(),
            "{}",
            run.stdout
        );
    }
}

#[test]
fn move_sends_position_2_everywhere_and_the_other_modes_where_they_exist() {
    for family in &families() {
        let run = rmd_on("move", family, &["move", "1", "--deg", "30"]);
        run.ok();
        let commands = run.commands();
        let ready = family.ready_to_move();
        assert_eq!(commands[..ready.len()], ready[..], "{}", family.name);
        let Request::Position2 {
            angle_control,
            max_speed,
        } = run.sent[ready.len()]
        else {
            panic!("{}: {:?}", family.name, run.sent);
        };
        assert_eq!((angle_control.raw(), max_speed.raw()), (3000, 360));
        assert!(
            commands[ready.len() + 1..]
                .iter()
                .all(|c| *c == Cmd::ReadMultiTurnAngle),
            "{}: {commands:?}",
            family.name
        );
        for (mode, command) in [
            ("1", Cmd::Position1),
            ("3", Cmd::Position3),
            ("4", Cmd::Position4),
        ] {
            let run = rmd_on(
                "move-mode",
                family,
                &["move", "1", "--deg", "30", "--mode", mode],
            );
            if family.is_v3() {
                assert_refused(&run, family, command, "use `rmd move ID --deg X --mode 2`");
            } else {
                run.ok();
                assert_eq!(run.sent[2].command(), command, "{}", family.name);
            }
        }
    }
}

#[test]
fn status_and_monitor_read_what_each_family_has() {
    for family in &families() {
        let run = rmd_on("status", family, &["status", "1", "--json"]);
        run.ok();
        let mut expected = family.identification();
        if family.is_v3() {
            expected.extend([
                Cmd::ReadStatus1,
                Cmd::ReadStatus2,
                Cmd::ReadMultiTurnAngle,
                Cmd::ReadSingleTurnAngle,
            ]);
        } else {
            expected.extend([
                Cmd::ReadStatus1,
                Cmd::ReadStatus2,
                Cmd::ReadStatus3,
                Cmd::ReadEncoder,
                Cmd::ReadMultiTurnAngle,
                Cmd::ReadSingleTurnAngle,
            ]);
        }
        assert_eq!(run.commands(), expected, "{}", family.name);
        let status: serde_json::Value = serde_json::from_str(run.stdout.trim()).unwrap();
        assert_eq!(status["voltage_volts"], 48.0, "{}", family.name);
        assert_eq!(status["firmware"], family.dialect.name());
        if family.is_v3() {
            assert_eq!(status["firmware_date"], SIM_V3_DATE);
            assert_eq!(status["brake_released"], true);
            assert!(status.get("output_angle_degrees").is_some(), "{status}");
        }

        let run = rmd_on(
            "monitor",
            family,
            &["monitor", "--ids", "1", "--count", "1", "--json"],
        );
        run.ok();
        let mut expected = family.identification();
        expected.extend([Cmd::ReadStatus1, Cmd::ReadStatus2, Cmd::ReadMultiTurnAngle]);
        assert_eq!(run.commands(), expected, "{}", family.name);
        let reading: serde_json::Value = serde_json::from_str(run.stdout.trim()).unwrap();
        assert_eq!(reading["motors"][0]["voltage_volts"], 48.0);
    }
}

#[test]
fn scan_sends_only_the_identifying_reads() {
    for family in &families() {
        let run = rmd_on("scan", family, &["scan", "--ids", "1", "--json"]);
        run.ok();
        assert_eq!(run.commands(), family.identification(), "{}", family.name);
        let list: serde_json::Value = serde_json::from_str(run.stdout.trim()).unwrap();
        assert_eq!(list[0]["firmware"], family.dialect.name());
        if family.is_v3() {
            assert_eq!(list[0]["firmware_date"], SIM_V3_DATE);
            assert_eq!(list[0]["firmware_revision"], "V4.3");
            assert_eq!(list[0]["model"], "RMD-SIM");
        } else {
            assert!(list[0].get("firmware_date").is_none());
        }
    }
}

#[test]
fn off_stop_and_run_in_each_familys_meaning() {
    for family in &families() {
        // Off is the same frame everywhere: sent at once, no identification.
        let run = rmd_on("off", family, &["off", "1"]);
        run.ok();
        assert_eq!(run.commands(), family.off(), "{}", family.name);
        let said = if family.is_v3() {
            "motor 1: off, brake locked\n"
        } else {
            "motor 1: off\n"
        };
        assert_eq!(run.stdout, said);

        let run = rmd_on("stop", family, &["stop", "1"]);
        run.ok();
        let mut expected = family.identification();
        expected.push(Cmd::MotorStop);
        assert_eq!(run.commands(), expected, "{}", family.name);
        assert_eq!(
            run.stdout.contains("holding its position"),
            family.is_v3(),
            "{}",
            run.stdout
        );

        let run = rmd_on("run", family, &["run", "1"]);
        if family.is_v3() {
            assert_refused(&run, family, Cmd::MotorRun, "send the motion again");
        } else {
            run.ok();
            assert_eq!(run.commands().last(), Some(&Cmd::MotorRun));
        }
    }
}

#[test]
fn settings_commands_work_or_refuse_before_sending() {
    // (command, what it sends after the identification on v1.61 and LK-TECH, what V3 lacks,
    // what V3 is told to use instead).
    let cases: [(&[&str], &[Cmd], Cmd, &str); 8] = [
        (
            &["pid", "get", "1"],
            &[Cmd::ReadPid],
            Cmd::ReadPid,
            "configuration software",
        ),
        (
            &["pid", "set", "1", "--speed-pid-kp", "61"],
            &[Cmd::ReadPid, Cmd::WritePidRam],
            Cmd::ReadPid,
            "configuration software",
        ),
        (
            &["pid", "set", "1", "--speed-pid-kp", "61", "--rom", "--yes"],
            &[Cmd::ReadPid, Cmd::WritePidRom],
            Cmd::ReadPid,
            "configuration software",
        ),
        (
            &["accel", "get", "1"],
            &[Cmd::ReadAccel],
            Cmd::ReadAccel,
            "0x42, 0x43",
        ),
        (
            &["accel", "set", "1", "1500"],
            &[Cmd::WriteAccelRam],
            Cmd::WriteAccelRam,
            "0x42, 0x43",
        ),
        (
            &["encoder", "get", "1"],
            &[Cmd::ReadEncoder],
            Cmd::ReadEncoder,
            "`rmd status`",
        ),
        (
            &["encoder", "offset", "1", "99", "--yes"],
            &[Cmd::WriteEncoderOffset],
            Cmd::WriteEncoderOffset,
            "0x63 / 0x64",
        ),
        (
            &["zero", "1", "--yes"],
            &[Cmd::WriteZeroRom],
            Cmd::WriteZeroRom,
            "0x63 / 0x64",
        ),
    ];
    for family in &families() {
        for (command, sends, missing, instead) in cases {
            let run = rmd_on("settings", family, command);
            if family.is_v3() {
                assert_refused(&run, family, missing, instead);
            } else {
                run.ok();
                let mut expected = family.identification();
                expected.extend_from_slice(sends);
                assert_eq!(run.commands(), expected, "{} {command:?}", family.name);
            }
        }
    }
}

#[test]
fn the_watchdog_is_v3s_and_asks_first() {
    for family in &families() {
        let run = rmd_on("watchdog", family, &["watchdog", "1", "100ms", "--yes"]);
        if !family.is_v3() {
            assert_refused(&run, family, Cmd::SetWatchdog, "no communication watchdog");
            continue;
        }
        run.ok();
        let mut expected = family.identification();
        expected.extend([Cmd::ReadStatus2, Cmd::SetWatchdog]);
        assert_eq!(run.commands(), expected);
        assert!(matches!(
            run.sent.last(),
            Some(Request::SetWatchdog { timeout }) if timeout.millis() == 100
        ));
        // Without --yes and without a terminal: identified, checked, not written.
        let run = rmd_on("watchdog-ask", family, &["watchdog", "1", "100ms"]);
        run.failed();
        assert!(run.stderr.contains("needs confirmation"), "{}", run.stderr);
        assert!(!run.commands().contains(&Cmd::SetWatchdog));
    }
}

#[test]
fn replay_sends_the_log_as_recorded_then_turns_the_moved_motor_off() {
    // A V3 session: 1 A (100 at 0.01 A) to motor 1. Replayed, the frames go out unchanged and
    // motor 1 is turned off (and its brake locked on V3) at the end.
    let dir = std::env::temp_dir().join(format!("rmd-families-{}-replay", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let session = dir.join("session.log");
    std::fs::write(&session, "(1.000000) can0 141#A100000064000000 T\n").unwrap();
    for family in &families() {
        let log = log_path("replay", family);
        let mut args = vec![
            "replay",
            session.to_str().unwrap(),
            "--sim",
            "--sim-ids",
            "1",
        ];
        args.extend(family.sim);
        args.extend(["--log", log.to_str().unwrap()]);
        let out = rmd(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let sent: Vec<CanFrame> = std::fs::read_to_string(&log)
            .unwrap()
            .lines()
            .map(|l| parse_line(l).unwrap())
            .filter(|l| l.direction == Some(FrameDirection::Tx))
            .map(|l| l.frame)
            .collect();
        assert_eq!(sent[0].to_string(), "141#A100000064000000");
        let off: Vec<Cmd> = sent_in(&log, family.dialect)[1..]
            .iter()
            .map(Request::command)
            .collect();
        assert_eq!(off, family.off(), "{}", family.name);
    }
}
