//! `rmd drill`: the stable interface scripts and CI run (JSON fields, exit status), on the
//! simulator's ground truth.

use assert_cmd::Command;
use serde_json::Value;

fn rmd(args: &[&str]) -> (i32, String, String) {
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs every kind of the matrix (`rmd drill --all`, virtual time, 0.6 s, fault at 0.2 s) with
/// `extra` arguments; checks that it exits 0 and that each of the 17 drills ended with every
/// motor safe by the simulated firmware's ground truth (none energised, none the loop believed
/// off but was not); returns the drills' JSON objects.
fn all_drills_end_safe(extra: &[&str]) -> Vec<Value> {
    let mut args = vec![
        "drill",
        "--all",
        "--virtual-time",
        "--json",
        "--seconds",
        "0.6",
        "--at",
        "0.2",
    ];
    args.extend_from_slice(extra);
    let (code, stdout, stderr) = rmd(&args);
    assert_eq!(code, 0, "{extra:?}: {stderr}");
    let drills: Vec<Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(drills.len(), 17, "{extra:?}");
    for d in &drills {
        assert_eq!(d["motors_energised_after"], 0, "{extra:?}: {d}");
        assert_eq!(
            d["believed_off_but_energised"],
            serde_json::json!([]),
            "{extra:?}: {d}"
        );
    }
    drills
}

#[test]
fn one_drill_prints_one_json_object_with_the_stable_fields() {
    let (code, stdout, stderr) = rmd(&[
        "drill",
        "--fault",
        "estop",
        "--buses",
        "2",
        "--at",
        "0.2",
        "--seconds",
        "0.5",
        "--virtual-time",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(stdout.lines().count(), 1);
    let json: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(json["fault"], "estop");
    assert_eq!(json["stop_reason"], "EMERGENCY STOP");
    assert_eq!(json["motors"], 8);
    assert_eq!(json["motors_energised_after"], 0);
    assert_eq!(json["confirmed_off"], 8);
    assert!(json["time_to_safe_ms"].as_f64().unwrap() < 5.0, "{json}");
    assert!(json["report"]["ticks"].as_u64().unwrap() > 150, "{json}");
}

#[test]
fn low_voltage_stops_the_run_where_the_health_rotation_has_room_and_says_why_not_elsewhere() {
    let drill = |motors: &str, json: bool| {
        let mut args = vec![
            "drill",
            "--fault",
            "low-voltage",
            "--motors",
            motors,
            "--at",
            "0.2",
            "--seconds",
            "0.5",
            "--virtual-time",
        ];
        if json {
            args.push("--json");
        }
        rmd(&args)
    };
    // Three motors at 1 kHz: the under-voltage flag stops the run, naming motor 1.
    let (code, stdout, stderr) = drill("3", true);
    assert_eq!(code, 0, "{stderr}");
    let json: Value = serde_json::from_str(&stdout).unwrap();
    let stop = json["stop_reason"].as_str().unwrap();
    assert!(
        stop.contains("motor 1 on bus 0") && stop.contains("under-voltage"),
        "{json}"
    );
    assert!(json["time_to_safe_ms"].as_f64().unwrap() < 10.0, "{json}");
    assert_eq!(json["report"]["health_rotation"], serde_json::json!([true]));
    let (code, stdout, stderr) = drill("3", false);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("under-voltage"), "{stdout}");
    // Four motors: no room on the wire; the run rides to its end and the verdict says why.
    let (code, stdout, stderr) = drill("4", false);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("stop: tick limit reached"), "{stdout}");
    assert!(
        stdout.contains("motor health: not read on bus 0"),
        "{stdout}"
    );
}

#[test]
fn an_emergency_stop_acts_while_the_controller_hangs() {
    // The controller hangs at 0.3 s; the estop comes 20 ms later, before the stall bound (50 ms):
    // the supervisor acts on it at once.
    for time in [&["--virtual-time"][..], &[]] {
        let mut args = vec![
            "drill",
            "--fault",
            "controller-hang:3000@0.3",
            "--fault",
            "estop@0.32",
            "--seconds",
            "0.6",
            "--json",
        ];
        args.extend_from_slice(time);
        let (code, stdout, stderr) = rmd(&args);
        assert_eq!(code, 0, "{stderr}");
        let json: Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(json["fault"], "controller-hang:3000 + estop");
        assert_eq!(json["stop_reason"], "EMERGENCY STOP", "{json}");
        assert_eq!(json["report"]["safe_stop"]["by"], "supervisor", "{json}");
        // From the hang: the estop 20 ms later, then the supervisor's safe stop. In real time,
        // a wide bound (a loaded machine); what matters is that it is well before the hang ends.
        let tts = json["time_to_safe_ms"].as_f64().unwrap();
        assert!((20.0..1000.0).contains(&tts), "{tts}");
    }
}

#[test]
fn motors_left_energised_exit_1_and_are_named() {
    // A bus-off longer than the safe stop waits for a restart.
    let (code, stdout, _) = rmd(&[
        "drill",
        "--fault",
        "bus-off:1500",
        "--at",
        "0.1",
        "--seconds",
        "0.3",
        "--virtual-time",
    ]);
    assert_eq!(code, 1);
    assert!(
        stdout.contains("drill bus-off:1500: MOTORS LEFT ENERGISED"),
        "{stdout}"
    );
    assert!(
        stdout.contains("energised after the run (simulated firmware): 4 of 4 (motor 1 on bus 0"),
        "{stdout}"
    );
    assert!(stdout.contains("time to safe: never"), "{stdout}");
    assert!(stdout.contains("may still be energised"), "{stdout}");
}

#[test]
fn all_runs_every_kind_once() {
    all_drills_end_safe(&[]);
    let (code, table, _) = rmd(&[
        "drill",
        "--all",
        "--virtual-time",
        "--seconds",
        "0.6",
        "--at",
        "0.2",
    ]);
    assert_eq!(code, 0);
    assert!(table.starts_with("fault "), "{table}");
    assert!(table.contains("controller-hang:3000"), "{table}");
    assert!(
        table
            .trim_end()
            .ends_with("every drill ended with every motor safe")
    );
}

/// Every kind of the matrix on MyActuator V3 motors (per-motor exchange, three per bus, two
/// buses; motion mode, two per bus, two buses) and on LK-TECH MG motors: each drill ends with
/// every motor safe by the simulated firmware's ground truth.
#[test]
fn every_kind_ends_safe_on_v3_and_lk_motors() {
    // V3 per motor, V3 in motion mode (two motors a bus: their temperature is watched by the
    // health rotation), LK-TECH with the 0x280 frame.
    for (firmware, exchange, buses, motors) in [
        ("myactuator-v3", "per-motor", "2", 6u64),
        ("myactuator-v3", "motion", "2", 4),
        ("lk-v2.3x", "multi-torque", "1", 4),
    ] {
        let drills = all_drills_end_safe(&[
            "--sim-firmware",
            firmware,
            "--exchange",
            exchange,
            "--buses",
            buses,
        ]);
        for d in &drills {
            // The undescribed motor 3 takes motor 3's place, or is one more beside two.
            let per_bus = motors / buses.parse::<u64>().unwrap();
            let extra = d["fault"] == "unknown-motor:3" && per_bus < 3;
            assert_eq!(d["motors"], motors + u64::from(extra), "{firmware}: {d}");
        }
    }
}

/// Every kind of the matrix on buses mixing families (v1.61 motors on odd ids, MyActuator V3 on
/// even ids, driven per motor, each in its own scale): each drill ends with every motor safe by
/// the simulated firmware's ground truth.
#[test]
fn every_kind_ends_safe_on_buses_mixing_families() {
    let drills = all_drills_end_safe(&[
        "--sim-firmware",
        "v1.61",
        "--mix-firmware",
        "myactuator-v3",
        "--buses",
        "2",
    ]);
    // Both families answered, on one bus.
    let stop = drills.iter().find(|d| d["fault"] == "stop").unwrap();
    let families: Vec<(u64, &str)> = stop["report"]["identified"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["bus"] == 0)
        .map(|m| (m["motor"].as_u64().unwrap(), m["family"].as_str().unwrap()))
        .collect();
    assert_eq!(
        families,
        [(1, "v1.61"), (2, "myactuator-v3"), (3, "v1.61")],
        "{stop}"
    );
}

/// Four V3 motors on one bus need more than a 1 kHz tick on the wire: refused before anything
/// runs, naming the rate the bus can carry.
#[test]
fn a_v3_layout_the_wire_cannot_carry_is_refused() {
    let (code, stdout, stderr) = rmd(&[
        "drill",
        "--fault",
        "stop",
        "--virtual-time",
        "--sim-firmware",
        "myactuator-v3",
        "--motors",
        "4",
    ]);
    assert_eq!(code, 2, "{stdout}{stderr}");
    assert!(
        stderr.contains("highest rate this bus can carry is 833 Hz"),
        "{stderr}"
    );
}

/// `host-silent:MS`: the host falls silent for good (nothing it sends reaches the motors, its
/// safe stop included). V3 motors with the watchdog in ROM turn themselves off within its
/// protection time by the firmware's ground truth; without it, and on v1.61 motors, which have
/// none, they stay energised and the drill says so.
#[test]
fn a_silent_host_leaves_only_the_motor_watchdog_to_stop_the_motors() {
    let drill = |firmware: &str, fault: &str| {
        let (code, stdout, stderr) = rmd(&[
            "drill",
            "--fault",
            fault,
            "--virtual-time",
            "--json",
            "--seconds",
            "1",
            "--sim-firmware",
            firmware,
        ]);
        let d: Value = serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{e}: {stderr}"));
        (code, d)
    };
    let (code, d) = drill("myactuator-v3", "host-silent:50");
    assert_eq!(code, 0, "{d}");
    assert_eq!(d["motors_energised_after"], 0, "{d}");
    let ms = d["time_to_safe_ms"].as_f64().unwrap();
    // The watchdog counts from the last frame each motor received: frames the host sent just
    // before the silence still arrive, up to one exchange on the wire later (3 V3 motors at
    // 1 Mbit/s: at most 810 us).
    assert!(ms > 0.0 && ms <= 50.0 + 0.81, "{d}");
    // The loop could not confirm anything: its frames never arrived.
    assert_eq!(d["confirmed_off"], 0, "{d}");
    for (firmware, fault, motors) in [
        ("myactuator-v3", "host-silent:0", 3),
        ("v1.61", "host-silent:50", 4),
    ] {
        let (code, d) = drill(firmware, fault);
        assert_eq!(code, 1, "{firmware} {fault}: {d}");
        assert_eq!(d["motors_energised_after"], motors, "{d}");
        assert!(d["time_to_safe_ms"].is_null(), "{d}");
    }
    let (code, stdout, _) = rmd(&[
        "drill",
        "--fault",
        "host-silent:50",
        "--virtual-time",
        "--seconds",
        "1",
    ]);
    assert_eq!(code, 1);
    assert!(
        stdout.contains("only a watchdog in the motor stops it then"),
        "{stdout}"
    );
}

#[test]
fn a_short_chaos_run_passes() {
    let (code, stdout, stderr) = rmd(&[
        "drill",
        "--chaos",
        "--seconds",
        "8",
        "--seed",
        "11",
        "--virtual-time",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let report: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["failures"].as_array().unwrap().len(), 0);
    assert!(report["drills"].as_array().unwrap().len() >= 17);
}

#[test]
fn bad_input_is_a_usage_error_naming_what_to_change() {
    for (args, says) in [
        (
            &["drill", "--fault", "melt"][..],
            "unknown fault kind `melt`",
        ),
        (
            &["drill", "--fault", "drop:2"],
            "not a probability from 0 to 1",
        ),
        (
            &["drill", "--fault", "stop", "--buses", "9"],
            "--buses 9: a drill runs on 1 to 8 buses",
        ),
        (
            &["drill", "--fault", "stop", "--at", "5"],
            "--at 5 s is not before the end of the run",
        ),
        (
            &["drill", "--fault", "stop", "--seconds", "inf"],
            "--seconds",
        ),
        (&["drill"], "--fault"),
        (
            &["drill", "--fault", "stop", "--all"],
            "cannot be used with",
        ),
    ] {
        let (code, _, stderr) = rmd(args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
}

/// The wait for a motor's watchdog after a silent host (here ten minutes, in real time) never
/// holds a Ctrl-C back: the drill is judged at once from what the firmware did so far (the
/// watchdog has not acted: energised) and ends with 130.
#[test]
fn ctrl_c_ends_the_wait_for_a_long_watchdog() {
    use nix::sys::signal::{Signal, kill};
    use nix::unistd::Pid;
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("rmd"))
        .args([
            "drill",
            "--fault",
            "host-silent:600000",
            "--sim-firmware",
            "myactuator-v3",
            "--seconds",
            "1",
            "--at",
            "0.2",
            "--json",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Once the drill says it waits for the watchdogs (the silence at 0.2 s and the run's one
    // second are over), Ctrl-C.
    let mut stderr = std::io::BufRead::lines(std::io::BufReader::new(child.stderr.take().unwrap()));
    let waiting = stderr
        .by_ref()
        .map_while(Result::ok)
        .any(|line| line.contains("for the motors' watchdogs to act (Ctrl-C ends the wait)"));
    assert!(waiting, "the drill never said it waits for the watchdogs");
    // The rest of stderr is read, so that the drill never writes into a closed pipe.
    let rest = std::thread::spawn(move || stderr.map_while(Result::ok).count());
    kill(Pid::from_raw(child.id() as i32), Signal::SIGINT).unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the drill still waits a minute after Ctrl-C"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert_eq!(status.code(), Some(130));
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut child.stdout.take().unwrap(), &mut stdout).unwrap();
    let d: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(d["motors_energised_after"], 3, "{d}");
    rest.join().unwrap();
}
