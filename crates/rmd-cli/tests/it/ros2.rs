//! `rmd ros2`: usage errors, and a short run on simulated motors with DDS on loopback (its
//! report and the node's counters). The node against an independent DDS, driven from the
//! outside: `tests/ros2/run.sh`.

use assert_cmd::Command;
use serde_json::Value;

const LEG4: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/robots/leg4.toml"
);

/// The same leg on MyActuator V3 motors (two buses of two, the per-motor exchange).
const LEG4_V3: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/robots/leg4-v3.toml"
);

fn rmd(args: &[&str]) -> (i32, String, String) {
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .arg("ros2")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_input_is_a_usage_error_naming_what_to_change() {
    let cases: &[(&[&str], &str)] = &[
        (&["--sim"], "--robot"),
        (&["--robot", LEG4, "--sim", "--virtual-time"], "real time"),
        (&["--robot", LEG4, "--sim", "--domain-id", "233"], "0..=232"),
        (
            &["--robot", LEG4, "--sim", "--namespace", "leg"],
            "namespace",
        ),
        (
            &["--robot", LEG4, "--sim", "--node-name", "my-node"],
            "node name",
        ),
        (
            &["--robot", LEG4, "--sim", "--joint-states-hz", "0"],
            "rate",
        ),
        (
            &["--robot", LEG4, "--sim", "--diagnostics-period", "0"],
            "above 0",
        ),
        (
            &[
                "--robot",
                LEG4,
                "--sim",
                "--servo",
                "/nonexistent/servo.toml",
            ],
            "servo",
        ),
        (
            &["--robot", "/nonexistent/robot.toml", "--sim"],
            "robot.toml",
        ),
        (&["--robot", LEG4, "--sim", "--iface", "can0"], "--sim"),
    ];
    for (args, says) in cases {
        let (code, stdout, stderr) = rmd(args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
        assert!(
            stderr.contains(says),
            "{args:?} should mention {says:?}: {stderr}"
        );
    }
}

#[test]
fn a_short_run_reports_the_loop_and_the_nodes_counters() {
    a_short_run_of(LEG4, 60);
}

/// A V3 robot runs the node the same way (its motors driven by the per-motor exchange).
#[test]
fn a_short_run_of_a_v3_robot_reports_the_same() {
    a_short_run_of(LEG4_V3, 20);
}

fn a_short_run_of(robot: &str, domains_from: u32) {
    // DDS on loopback only, in a domain of this test's own.
    let domain = (domains_from + std::process::id() % 40).to_string();
    let (code, stdout, stderr) = rmd(&[
        "--robot",
        robot,
        "--sim",
        "--seconds",
        "1.5",
        "--network",
        "127.0.0.1",
        "--domain-id",
        &domain,
        "--namespace",
        "/cli_test",
        "--diagnostics-period",
        "200ms",
        "--json",
    ]);
    // On a loaded machine the 1 kHz loop may be starved enough to stop on a fault (exit 1);
    // either way the report comes, every motor ends off, and the node's counters are sound.
    assert!(code == 0 || code == 1, "exit {code}: {stderr}{stdout}");
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    let json: Value = serde_json::from_str(&stdout).unwrap();
    let off = json["safe_stop"]["motors"].as_array().unwrap();
    assert_eq!(off.len(), 4, "{json}");
    assert!(off.iter().all(|m| m["off_confirmed"] == true), "{json}");
    let ros2 = &json["ros2"];
    if code == 0 {
        assert_eq!(json["stop_reason"], "tick limit reached", "{json}");
        assert!(json["ticks"].as_u64().unwrap() > 500, "{json}");
        // At 500 Hz for 1.5 s: well above what a loaded machine could miss.
        assert!(
            ros2["joint_states_published"].as_u64().unwrap() > 100,
            "{ros2}"
        );
        assert!(
            ros2["diagnostics_published"].as_u64().unwrap() >= 3,
            "{ros2}"
        );
    } else {
        // The faults a starved loop meets: deadlines missed, replies read too late, a tick
        // that did not complete within the stall bound.
        let reason = json["stop_reason"].as_str().unwrap();
        assert!(
            [
                "consecutive deadline misses",
                "gave no fresh feedback",
                "did not complete within"
            ]
            .iter()
            .any(|starved| reason.contains(starved)),
            "exit 1 for another reason: {json}"
        );
    }
    assert_eq!(ros2["publish_errors"], 0);
    assert_eq!(ros2["rejected_total"], 0);
    assert_eq!(ros2["rejected"].as_object().unwrap().len(), 12, "{ros2}");
}
