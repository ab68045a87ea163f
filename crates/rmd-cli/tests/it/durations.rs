//! Every time flag of every command (durations, periods in whole units, rates that set a period,
//! the replay speed) refuses a value it cannot represent (infinite, NaN, negative, far too large
//! or far too small) with a usage error (exit 2) that names the flag, before anything runs, and
//! never panics.

use crate::support;
use support::{fails, ok};

/// One flag of one command: the command line before the flag, the flag, the name the error
/// gives it, and the values it must refuse.
struct Row {
    command: &'static [&'static str],
    flag: &'static str,
    named: &'static str,
    bad: &'static [&'static str],
}

/// Values no duration can be.
const DURATIONS: &[&str] = &["inf", "-inf", "NaN", "-1", "1e300", "1e400", "soon"];
/// Values no whole number of microseconds or milliseconds can be.
const WHOLE: &[&str] = &["inf", "NaN", "-1", "1e300", "1e-300", "1.5"];
/// Rates whose period cannot be represented, or that are not rates.
const RATES: &[&str] = &["inf", "-inf", "NaN", "-1", "0", "1e-300"];

fn row(command: &'static [&'static str], flag: &'static str, bad: &'static [&'static str]) -> Row {
    Row {
        command,
        flag,
        named: flag,
        bad,
    }
}

/// Every time flag. (`rmd log --iface vcan0 FILE` and `rmd sim --iface vcan0` fail on their
/// flags before they look for the interface.)
fn rows() -> Vec<Row> {
    const TORQUE: &[&str] = &["torque", "1", "--amps", "0.1", "--sim"];
    const SPEED: &[&str] = &["speed", "1", "--dps", "10", "--sim"];
    const MOVE: &[&str] = &["move", "1", "--deg", "10", "--sim"];
    const MONITOR: &[&str] = &["monitor", "--sim", "--count", "1"];
    const LOG: &[&str] = &["log", "--iface", "vcan0", "/nonexistent/rmd-durations.log"];
    const SIM: &[&str] = &["sim", "--iface", "vcan0"];
    const LOOP: &[&str] = &["bench", "loop", "--virtual-time"];
    const JITTER: &[&str] = &["bench", "jitter"];
    const RATE: &[&str] = &["bench", "rate", "--virtual-time"];
    const REPLAY: &[&str] = &["replay", "/nonexistent/rmd-durations.log"];
    vec![
        // Durations with units (rmd_rig::args::duration).
        row(TORQUE, "--duration", DURATIONS),
        Row {
            command: TORQUE,
            flag: "--seconds",
            named: "--duration",
            bad: DURATIONS,
        },
        row(SPEED, "--duration", DURATIONS),
        row(MOVE, "--wait-timeout", DURATIONS),
        row(LOG, "--duration", DURATIONS),
        row(LOOP, "--duration", DURATIONS),
        row(JITTER, "--duration", DURATIONS),
        row(RATE, "--duration", DURATIONS),
        // Whole microseconds or milliseconds.
        row(TORQUE, "--timeout-ms", WHOLE),
        row(&["status", "1", "--sim"], "--timeout-ms", WHOLE),
        row(MONITOR, "--timeout-ms", WHOLE),
        row(REPLAY, "--timeout-ms", WHOLE),
        row(SIM, "--turnaround-us", WHOLE),
        row(SIM, "--jitter-us", WHOLE),
        row(
            SIM,
            "--late",
            &["0.1,inf", "0.1,NaN", "0.1,-1", "0.1,1e300", "0.1"],
        ),
        row(JITTER, "--period-us", WHOLE),
        row(LOOP, "--spin-us", WHOLE),
        row(JITTER, "--spin-us", WHOLE),
        row(RATE, "--spin-us", WHOLE),
        row(RATE, "--rx-spin-us", WHOLE),
        // Rates that set a period.
        row(TORQUE, "--rate", RATES),
        Row {
            command: SPEED,
            flag: "--rate-hz",
            named: "--rate",
            bad: RATES,
        },
        row(MONITOR, "--rate", RATES),
        row(LOOP, "--rate", RATES),
        row(RATE, "--rate", RATES),
        // A factor that divides the log's pauses.
        row(
            REPLAY,
            "--speed",
            &["inf", "NaN", "-1", "0", "1e-300", "1e300"],
        ),
    ]
}

#[test]
fn every_time_flag_refuses_unrepresentable_values_naming_the_flag() {
    let mut checked = 0;
    for row in rows() {
        for bad in row.bad {
            let mut args = row.command.to_vec();
            args.extend([row.flag, bad]);
            let stderr = fails(2, &args);
            let line = args.join(" ");
            assert!(
                stderr.contains(&format!("'{}", row.named)),
                "rmd {line}: the error does not name {}: {stderr}",
                row.named
            );
            assert!(!stderr.contains("panicked"), "rmd {line}: {stderr}");
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");
}

#[test]
fn representable_values_still_parse() {
    // The edges: a zero-length drive (one command, then motor-off), a rate above what the motor
    // answers, the slowest rate, the longest reply timeout.
    for args in [
        &["torque", "1", "--amps", "0.1", "--sim", "--duration", "0"][..],
        &[
            "speed",
            "1",
            "--dps",
            "10",
            "--sim",
            "--seconds",
            "0.01",
            "--rate",
            "1e300",
        ],
        &[
            "monitor", "--sim", "--ids", "1", "--count", "1", "--rate", "1e-9",
        ],
        &["status", "1", "--sim", "--timeout-ms", "60000"],
    ] {
        ok(args);
    }
}
