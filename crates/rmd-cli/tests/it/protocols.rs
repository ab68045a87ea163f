//! Other firmware on a live bus, against the in-process simulator (`--sim --sim-firmware`):
//! `--protocol lk-v2.3x` on the live commands, and what a v1.61 host sees without it. No
//! assertion depends on timing.

use std::path::PathBuf;

use rmd_bus::candump::{FrameDirection, parse_line};
use serde_json::Value;

use crate::support;
use support::{fails, ok};

fn json_lines(stdout: &str) -> Vec<Value> {
    stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

/// A fresh log file path in a per-test directory.
fn log_path(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rmd-protocols-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join("bus.log")
}

#[test]
fn status_of_lk_motors_reads_the_lk_layout() {
    // The simulated MG motor is at 48 V, written LK's way: 4800 at 0.01 V in DATA[2..=3].
    let out = ok(&[
        "status",
        "1",
        "--sim",
        "--sim-firmware",
        "lk-v2.3x",
        "--protocol",
        "lk-v2.3x",
        "--lk-series",
        "mg",
        "--json",
    ]);
    let status = &json_lines(&out)[0];
    assert_eq!(status["voltage_volts"], 48.0, "{status}");
    assert_eq!(status["temperature_celsius"], 25.0);
    assert_eq!(status["circle_angle_degrees"], 0.0);
    let human = ok(&[
        "status",
        "1",
        "--sim",
        "--sim-firmware",
        "lk-v2.3x",
        "--protocol",
        "lk-v2.3x",
        "--lk-series",
        "mg",
    ]);
    assert!(human.contains("voltage          48.0 V"), "{human}");
    // Named v1.61, the same motor shows issue 14's trap: DATA[3..=4] = 0x0012 (the name is the
    // user's word: 0x9A alone cannot always tell v1.61 from LK-TECH).
    let out = ok(&[
        "status",
        "1",
        "--sim",
        "--sim-firmware",
        "lk-v2.3x",
        "--protocol",
        "v1.61",
        "--json",
    ]);
    assert_eq!(json_lines(&out)[0]["voltage_volts"], 1.8);
    // Not named: identified as LK-TECH, read in its layout with the series given...
    let out = ok(&[
        "status",
        "1",
        "--sim",
        "--sim-firmware",
        "lk-v2.3x",
        "--lk-series",
        "mg",
        "--json",
    ]);
    assert_eq!(json_lines(&out)[0]["voltage_volts"], 48.0);
    assert_eq!(json_lines(&out)[0]["firmware"], "lk-v2.3x");
    // ...and without it the current (status 2) is not guessed.
    let err = fails(1, &["status", "1", "--sim", "--sim-firmware", "lk-v2.3x"]);
    assert!(
        err.contains("add --lk-series mf (MF motors, ±16.5 A) or --lk-series mg"),
        "{err}"
    );
}

#[test]
fn torque_on_an_lk_mf_motor_uses_its_scale() {
    let log = log_path("torque-mf");
    let out = ok(&[
        "torque",
        "1",
        "--amps",
        "2",
        "--duration",
        "100ms",
        "--sim",
        "--sim-firmware",
        "lk-v2.3x",
        "--protocol",
        "lk-v2.3x",
        "--lk-series",
        "mf",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert!(out.contains("then turned off"), "{out}");
    // 2 A on an MF motor: 2 × 2048 / 16.5 = 248.2 -> 248 = 0xF8 (v1.61 would send 125 = 0x7D).
    let sent: Vec<String> = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(|l| parse_line(l).unwrap())
        .filter(|l| l.direction == Some(FrameDirection::Tx))
        .map(|l| l.frame.to_string())
        .collect();
    assert!(sent.len() >= 3, "{sent:?}");
    let (last, drive) = sent.split_last().unwrap();
    // The named protocol checked first (status 1 in LK-TECH's layout), then only MF torque.
    assert_eq!(drive[0], "141#9A00000000000000");
    assert!(
        drive[1..].iter().all(|f| f == "141#A1000000F8000000"),
        "{sent:?}"
    );
    assert_eq!(last, "141#8000000000000000");
    // Beyond the MF range: refused before anything is sent.
    let err = fails(
        1,
        &[
            "torque",
            "1",
            "--amps",
            "20",
            "--sim",
            "--sim-firmware",
            "lk-v2.3x",
            "--protocol",
            "lk-v2.3x",
            "--lk-series",
            "mf",
        ],
    );
    assert!(
        err.contains("cannot send torque to motor 1 in protocol lk-v2.3x (MF)"),
        "{err}"
    );
}

#[test]
fn a_motor_of_another_family_than_named_is_named_not_timed_out() {
    let err = fails(
        1,
        &[
            "status",
            "2",
            "--sim",
            "--sim-firmware",
            "myactuator-v3",
            "--protocol",
            "v1.61",
            "--timeout-ms",
            "5",
        ],
    );
    assert!(
        err.contains(
            "motor 2 answered read-status-1 on 0x242 (0x240 + id), as MyActuator V3 firmware \
             does, not protocol v1.61"
        ),
        "{err}"
    );
    let err = fails(
        1,
        &[
            "torque",
            "2",
            "--amps",
            "1",
            "--sim",
            "--protocol",
            "myactuator-v3",
            "--timeout-ms",
            "5",
        ],
    );
    assert!(
        err.contains(
            "motor 2 answered read-status-1 on 0x142 (0x140 + id), as v1.61 and LK-TECH \
             firmware do, not protocol myactuator-v3"
        ),
        "{err}"
    );
}

#[test]
fn protocol_and_firmware_options_are_checked() {
    let err = fails(2, &["status", "1", "--sim", "--protocol", "lk-v2.3x"]);
    assert!(err.contains("--lk-series mf or --lk-series mg"), "{err}");
    // --lk-series with another protocol is a mistake, unless it is the simulated LK motors'
    // series; alone, it is the series of the motors identified as LK-TECH.
    let err = fails(
        2,
        &[
            "status",
            "1",
            "--sim",
            "--protocol",
            "v1.61",
            "--lk-series",
            "mf",
        ],
    );
    assert!(err.contains("add --protocol lk-v2.3x"), "{err}");
    ok(&["status", "1", "--sim", "--lk-series", "mf"]);
    ok(&[
        "status",
        "1",
        "--sim",
        "--sim-firmware",
        "lk-v2.3x",
        "--lk-series",
        "mf",
    ]);
    let err = fails(
        2,
        &["status", "1", "--iface", "vcan9", "--sim-firmware", "v1.61"],
    );
    assert!(err.contains("--sim"), "{err}");
    let err = fails(2, &["scan", "--sim", "--sim-firmware", "v2"]);
    assert!(
        err.contains("expected v1.61, lk-v2.3x or myactuator-v3"),
        "{err}"
    );
    let err = fails(
        2,
        &["status", "1", "--sim", "--firmware-date", "2026042402"],
    );
    assert!(err.contains("add --protocol myactuator-v3"), "{err}");
}

/// `rmd scan ARGS --json`: the array's objects.
fn scan_json(args: &[&str]) -> Vec<Value> {
    let mut all = vec!["scan", "--json"];
    all.extend_from_slice(args);
    match json_lines(&ok(&all)).remove(0) {
        Value::Array(list) => list,
        other => panic!("not an array: {other}"),
    }
}

#[test]
fn scan_identifies_each_simulated_family() {
    // Ids 5 and 6 are probed too and absent: not listed.
    for (firmware, reply_base) in [
        ("v1.61", 0x140),
        ("lk-v2.3x", 0x140),
        ("myactuator-v3", 0x240),
    ] {
        let list = scan_json(&["--sim", "--sim-firmware", firmware, "--ids", "1-6"]);
        let ids: Vec<u64> = list.iter().map(|m| m["id"].as_u64().unwrap()).collect();
        assert_eq!(ids, [1, 2, 3, 4], "{firmware}");
        for m in &list {
            assert_eq!(m["firmware"], firmware, "{m}");
            assert_eq!(m["ambiguous"], false, "{m}");
            let id = m["id"].as_u64().unwrap();
            assert_eq!(
                m["evidence"]["reply_id"],
                format!("0x{:03X}", reply_base + id),
                "{m}"
            );
            assert_eq!(m["evidence"]["answered_status1"], true);
            assert_eq!(m["evidence"]["answered_status2"], true);
            // Status 1 in the family's own layout: the simulated supply is 48 V.
            assert_eq!(m["voltage_volts"], 48.0, "{m}");
        }
    }
    // The evidence of an LK motor: its 0x9A read both ways.
    let lk = &scan_json(&["--sim", "--sim-firmware", "lk-v2.3x", "--ids", "1"])[0];
    assert_eq!(lk["evidence"]["lk_volts"], 48.0);
    assert_eq!(lk["evidence"]["v161_volts"], 1.8);
    assert_eq!(lk["voltage"], 4800);
    assert_eq!(lk["motor_state_name"], "on");
    // A V3 motor's model, read with 0xB5.
    let v3 = &scan_json(&["--sim", "--sim-firmware", "myactuator-v3", "--ids", "2"])[0];
    assert_eq!(v3["model"], "RMD-SIM");
    assert!(v3["evidence"].get("v161_volts").is_none());
}

#[test]
fn scan_of_a_mixed_bus_names_each_motors_firmware() {
    let args = [
        "--sim",
        "--sim-ids",
        "1-3,5",
        "--sim-firmware",
        "lk-v2.3x,v1.61,myactuator-v3,lk-v2.3x",
        "--lk-series",
        "mf",
        "--ids",
        "1-8",
    ];
    let list = scan_json(&args);
    let found: Vec<(u64, &str)> = list
        .iter()
        .map(|m| (m["id"].as_u64().unwrap(), m["firmware"].as_str().unwrap()))
        .collect();
    assert_eq!(
        found,
        [
            (1, "lk-v2.3x"),
            (2, "v1.61"),
            (3, "myactuator-v3"),
            (5, "lk-v2.3x")
        ]
    );
    // The table: one row per motor, with its firmware and the V3 motor's model.
    let mut human = vec!["scan"];
    human.extend_from_slice(&args);
    let table = ok(&human);
    let rows: Vec<Vec<&str>> = table
        .lines()
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(rows[0][..2], ["id", "firmware"]);
    let firmware: Vec<&str> = rows[1..].iter().map(|r| r[1]).collect();
    assert_eq!(firmware, ["lk-v2.3x", "v1.61", "myactuator-v3", "lk-v2.3x"]);
    assert!(table.contains("model RMD-SIM"), "{table}");
}

#[test]
fn sim_firmware_lists_must_fit_the_motors() {
    let err = fails(
        2,
        &[
            "scan",
            "--sim",
            "--sim-ids",
            "1-3",
            "--sim-firmware",
            "v1.61,lk-v2.3x",
        ],
    );
    assert!(
        err.contains("--sim-firmware lists 2 firmware families for 3 simulated motors"),
        "{err}"
    );
    let err = fails(
        1,
        &[
            "scan",
            "--sim",
            "--sim-firmware",
            "lk-v2.3x",
            "--ids",
            "9-10",
        ],
    );
    assert!(err.contains("no motor answered"), "{err}");
}
