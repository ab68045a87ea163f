//! `rmd encode`: every command, with expected frames worked out by hand from the spec, and the
//! error contract (non-zero exit, one line on stderr, nothing on stdout).

use assert_cmd::Command;

fn rmd() -> Command {
    Command::cargo_bin("rmd").unwrap()
}

/// Runs `rmd encode ARGS` and returns stdout, asserting success and a silent stderr.
fn encode(args: &str) -> String {
    let out = rmd()
        .arg("encode")
        .args(args.split_whitespace())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "rmd encode {args}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stderr.is_empty(), "stderr for {args}");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn issue_example() {
    assert_eq!(
        encode("torque --id 1 --iq-control 100"),
        "141#A100000064000000\n"
    );
}

#[test]
fn every_command() {
    let cases = [
        ("read-pid --id 1", "141#3000000000000000"),
        ("read-accel --id 4", "144#3300000000000000"),
        (
            "write-accel-ram --id 1 --accel 10000",
            "141#3400000010270000",
        ),
        ("read-encoder --id 1", "141#9000000000000000"),
        (
            "write-encoder-offset --id 1 --encoder-offset 4660",
            "141#9100000000003412",
        ),
        ("write-zero-rom --id 1", "141#1900000000000000"),
        ("read-multi-turn-angle --id 1", "141#9200000000000000"),
        ("read-single-turn-angle --id 1", "141#9400000000000000"),
        ("read-status-1 --id 1", "141#9A00000000000000"),
        ("clear-error --id 1", "141#9B00000000000000"),
        ("read-status-2 --id 1", "141#9C00000000000000"),
        ("read-status-3 --id 1", "141#9D00000000000000"),
        ("motor-off --id 1", "141#8000000000000000"),
        ("motor-stop --id 1", "141#8100000000000000"),
        ("motor-run --id 32", "160#8800000000000000"),
        ("torque --id 32 --iq-control -100", "160#A10000009CFF0000"),
        ("torque --id 1 --amps 1.6", "141#A100000064000000"),
        ("speed --id 1 --speed-control 36000", "141#A2000000A08C0000"),
        ("speed --id 1 --dps -0.01", "141#A2000000FFFFFFFF"),
        (
            "position-1 --id 1 --angle-control -9000",
            "141#A3000000D8DCFFFF",
        ),
        ("position-1 --id 1 --deg -90", "141#A3000000D8DCFFFF"),
        (
            "position-2 --id 1 --max-speed 500 --angle-control 18000",
            "141#A400F40150460000",
        ),
        (
            "position-3 --id 1 --spin-direction ccw --angle-control 35999",
            "141#A50100009F8C0000",
        ),
        (
            "position-4 --id 1 --spin-direction cw --max-speed 360 --angle-control 9000",
            "141#A600680128230000",
        ),
        (
            "position-4 --id 1 --spin-direction cw --max-speed 360 --deg 90",
            "141#A600680128230000",
        ),
        (
            "multi-torque --iq-control 100,-100,0,2000",
            "280#64009CFF0000D007",
        ),
        (
            "multi-torque --amps -32,0.016,-0.016,8",
            "280#30F80100FFFFF401",
        ),
    ];
    for (args, expected) in cases {
        assert_eq!(encode(args), format!("{expected}\n"), "rmd encode {args}");
    }
}

#[test]
fn write_pid_commands() {
    // DATA[2..=7] = anglePidKp, anglePidKi, speedPidKp, speedPidKi, iqPidKp, iqPidKi.
    assert_eq!(
        encode(
            "write-pid-ram --id 2 --angle-pid-kp 100 --angle-pid-ki 50 --speed-pid-kp 40 \
             --speed-pid-ki 30 --iq-pid-kp 20 --iq-pid-ki 10"
        ),
        "142#31006432281E140A\n"
    );
    assert_eq!(
        encode(
            "write-pid-rom --id 3 --angle-pid-kp 1 --angle-pid-ki 2 --speed-pid-kp 3 \
             --speed-pid-ki 4 --iq-pid-kp 5 --iq-pid-ki 255"
        ),
        "143#32000102030405FF\n"
    );
}

#[test]
fn negative_values_with_equals_sign() {
    assert_eq!(
        encode("torque --id 1 --iq-control=-100"),
        "141#A10000009CFF0000\n"
    );
}

/// Runs `rmd encode ARGS`, asserting the error contract; returns the stderr line.
fn encode_error(args: &str) -> String {
    let out = rmd()
        .arg("encode")
        .args(args.split_whitespace())
        .output()
        .unwrap();
    assert!(!out.status.success(), "rmd encode {args} should fail");
    assert!(out.stdout.is_empty(), "stdout for {args}: {:?}", out.stdout);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(
        stderr.lines().count(),
        1,
        "one stderr line for {args}: {stderr:?}"
    );
    assert!(stderr.ends_with('\n'));
    stderr
}

#[test]
fn errors_are_one_line_on_stderr() {
    let cases = [
        (
            "torque --id 1 --iq-control 2001",
            "iq_control 2001 is out of range -2000..=2000",
        ),
        (
            "torque --id 1 --iq-control -2500",
            "iq_control -2500 is out of range -2000..=2000",
        ),
        (
            "torque --id 1 --amps 32.5",
            "iq_control 2031 is out of range",
        ),
        (
            "torque --id 1 --amps nan",
            "iq_control must be a finite number",
        ),
        ("torque --id 1", "--iq-control"),
        ("torque --iq-control 5", "--id"),
        (
            "torque --id 0 --iq-control 5",
            "invalid motor id 0: must be 1..=32",
        ),
        (
            "torque --id 33 --iq-control 5",
            "invalid motor id 33: must be 1..=32",
        ),
        (
            "torque --id 1 --iq-control 5 --amps 1",
            "cannot be used with",
        ),
        ("torque --id 1 --iq-control abc", "`abc` is not an integer"),
        (
            "position-3 --id 1 --spin-direction ccw --angle-control 36000",
            "angle_control 36000 is out of range 0..=35999",
        ),
        (
            "position-3 --id 1 --spin-direction up --angle-control 0",
            "invalid value 'up'",
        ),
        (
            "position-4 --id 1 --spin-direction cw --angle-control 0",
            "--max-speed",
        ),
        (
            "position-2 --id 1 --max-speed 70000 --angle-control 0",
            "max_speed 70000 is out of range 0..=65535",
        ),
        (
            "write-encoder-offset --id 1 --encoder-offset 16384",
            "encoder value 16384 is out of range 0..=16383 for a 14-bit encoder",
        ),
        (
            "write-encoder-offset --id 1 --encoder-offset 4096 --encoder-bits 12",
            "encoder value 4096 is out of range 0..=4095 for a 12-bit encoder",
        ),
        (
            "write-encoder-offset --id 1 --encoder-offset 1 --encoder-bits 20",
            "encoder width (bits) 20 is out of range 12..=18",
        ),
        (
            "write-pid-ram --id 1 --angle-pid-kp 256 --angle-pid-ki 0 --speed-pid-kp 0 \
             --speed-pid-ki 0 --iq-pid-kp 0 --iq-pid-ki 0",
            "256",
        ),
        ("write-pid-ram --id 1 --angle-pid-kp 1", "--angle-pid-ki"),
        (
            "write-accel-ram --id 1 --accel 3000000000",
            "accel 3000000000 is out of range",
        ),
        (
            "multi-torque --iq-control 1,2,3",
            "expected 4 comma-separated values (motors 1..=4), got 3",
        ),
        (
            "multi-torque --iq-control 1,2,3,2001",
            "iq_control 2001 is out of range",
        ),
        (
            "multi-torque --id 1 --iq-control 1,2,3,4",
            "unexpected argument '--id'",
        ),
        ("frobnicate --id 1", "unrecognized subcommand 'frobnicate'"),
    ];
    for (args, needle) in cases {
        let stderr = encode_error(args);
        assert!(stderr.starts_with("error: "), "{args}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{args}: {stderr:?} lacks {needle:?}"
        );
    }
}

#[test]
fn usage_errors_exit_2() {
    let out = rmd()
        .args(["encode", "torque", "--id", "1", "--iq-control", "9999"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn help_lists_every_command() {
    let out = rmd().args(["encode", "--help"]).output().unwrap();
    assert!(out.status.success());
    let help = String::from_utf8(out.stdout).unwrap();
    for name in rmd_protocol::Command::ALL.map(|c| c.name()) {
        assert!(help.contains(name), "{name} missing from help");
    }
    assert!(help.contains("multi-torque"));
}

#[test]
fn lk_tech_torque_frames() {
    // LK-TECH V2.35, 0xA1: iqControl ±2048 is ±16.5 A on MF motors, ±33 A on MG motors.
    let cases = [
        // 8.25 A on an MF motor is raw 1024 = 0x0400; 16.5 A on an MG one too.
        (
            "--protocol lk-v2.3x --lk-series mf torque --id 1 --amps 8.25",
            "141#A100000000040000",
        ),
        (
            "--protocol lk-v2.3x --lk-series mg torque --id 1 --amps 16.5",
            "141#A100000000040000",
        ),
        // 1 A on MF: 2048 / 16.5 = 124.12 -> 124 = 0x7C.
        (
            "--protocol lk-v2.3x --lk-series mf torque --id 1 --amps 1",
            "141#A10000007C000000",
        ),
        // Full scale, raw and in amperes (-2048 = 0xF800).
        (
            "--protocol lk-v2.3x --lk-series mg torque --id 2 --amps -33",
            "142#A100000000F80000",
        ),
        (
            "--protocol lk-v2.3x --lk-series mf torque --id 3 --iq-control 2048",
            "143#A100000000080000",
        ),
        // The options after the subcommand work too.
        (
            "torque --id 1 --amps 8.25 --protocol lk-v2.3x --lk-series mf",
            "141#A100000000040000",
        ),
        // 0x280 with the MG scale: 33, -33, 0, 16.5 A.
        (
            "--protocol lk-v2.3x --lk-series mg multi-torque --amps 33,-33,0,16.5",
            "280#000800F800000004",
        ),
        (
            "--protocol lk-v2.3x --lk-series mf multi-torque --iq-control 2048,-2048,0,1",
            "280#000800F800000100",
        ),
        // Frames whose layout LK shares are v1.61's.
        (
            "--protocol lk-v2.3x --lk-series mf read-status-1 --id 1",
            "141#9A00000000000000",
        ),
        (
            "--protocol v1.61 torque --id 1 --amps 1.6",
            "141#A100000064000000",
        ),
    ];
    for (args, frame) in cases {
        assert_eq!(encode(args), format!("{frame}\n"), "rmd encode {args}");
    }
}

#[test]
fn lk_tech_ranges_and_options_are_checked() {
    let cases = [
        (
            "--protocol lk-v2.3x --lk-series mf torque --id 1 --amps 20",
            "--amps 20: lk-v2.3x (MF) takes -16.5..=16.5 A; iq_control 2482 is out of range -2048..=2048",
        ),
        (
            "--protocol lk-v2.3x --lk-series mg torque --id 1 --iq-control 2049",
            "iq_control 2049 is out of range -2048..=2048 in lk-v2.3x (MG)",
        ),
        (
            "torque --id 1 --iq-control 2048",
            "iq_control 2048 is out of range -2000..=2000",
        ),
        (
            "--protocol lk-v2.3x torque --id 1 --amps 1",
            "--lk-series mf or --lk-series mg",
        ),
        (
            "--lk-series mf torque --id 1 --amps 1",
            "add --protocol lk-v2.3x",
        ),
        (
            "--protocol lk-v2.3x --lk-series ms torque --id 1 --amps 1",
            "expected mf or mg",
        ),
        (
            "--protocol lk-v2.3x --lk-series mf read-model --id 1",
            "read-model (0xB5) is not a command of protocol lk-v2.3x",
        ),
    ];
    for (args, needle) in cases {
        let stderr = encode_error(args);
        assert!(
            stderr.contains(needle),
            "{args}: {stderr:?} lacks {needle:?}"
        );
    }
}

#[test]
fn help_says_which_scale_each_current_option_assumes() {
    let out = rmd().args(["encode", "torque", "--help"]).output().unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "32/2000 A per LSB in v1.61",
        "16.5/2048 A (LK MF)",
        "33/2048 A (LK MG)",
    ] {
        assert!(help.contains(needle), "{needle} missing from {help}");
    }
}

/// MyActuator V3 (V4.3 / V4.4 manuals): the manuals' own example frames, byte for byte, and the
/// line scripts rely on.
#[test]
fn myactuator_v3_frames_are_the_manuals_examples() {
    let v3 = "--protocol myactuator-v3";
    let cases = [
        // Stable for scripts (issue 25): 1 A at 0.01 A/LSB (V4.3 §2.19 example 1).
        ("torque --id 1 --amps 1", "141#A100000064000000"),
        // V4.3 §2.19 example 2: -1 A.
        ("torque --id 1 --amps -1", "141#A10000009CFF0000"),
        // V4.3 §2.20: 100 dps at the output shaft, then with a 50 % torque limit.
        ("speed --id 1 --dps 100", "141#A200000010270000"),
        (
            "speed --id 1 --dps 100 --max-torque 50",
            "141#A232000010270000",
        ),
        // V4.3 §2.21: 360 degrees at 500 dps, and -360.
        (
            "position-2 --id 1 --max-speed 500 --deg 360",
            "141#A400F401A08C0000",
        ),
        (
            "position-2 --id 1 --max-speed 500 --deg -360",
            "141#A400F4016073FFFF",
        ),
        ("read-status-1 --id 1", "141#9A00000000000000"),
        ("read-status-2 --id 1", "141#9C00000000000000"),
        ("read-multi-turn-angle --id 1", "141#9200000000000000"),
        ("read-single-turn-angle --id 1", "141#9400000000000000"),
        ("motor-off --id 1", "141#8000000000000000"),
        ("motor-stop --id 1", "141#8100000000000000"),
        // V4.3 §2.30, §2.33 / V4.4 §2.34 (the indexed form).
        ("read-firmware-date --id 1", "141#B200000000000000"),
        ("read-model --id 1", "141#B500000000000000"),
        ("read-model --id 1 --index 1", "141#B501010000000000"),
        // V4.3 §2.31: 1000 ms, u32 in DATA[4..=7].
        (
            "set-watchdog --id 1 --timeout-ms 1000",
            "141#B3000000E8030000",
        ),
        // V4.3 §2.35: index 2 (CAN ID filter), value 1.
        (
            "function-control --id 1 --function can-id-filter --value 1",
            "141#2002000001000000",
        ),
        ("reset --id 1", "141#7600000000000000"),
        ("brake-release --id 1", "141#7700000000000000"),
        ("brake-lock --id 1", "141#7800000000000000"),
        // V4.3 §3: one command for every motor on 0x280.
        ("motor-off --broadcast", "280#8000000000000000"),
        ("torque --broadcast --amps 1", "280#A100000064000000"),
        // V4.3 §5.4: the motion-mode example, with its values (p 10 rad, v 1.021 rad/s,
        // kp 10.012, kd 1, t 10.004 N·m).
        (
            "motion --id 1 --p-des 10 --v-des 1.021 --kp 10.012 --kd 1 --t-ff 10.004",
            "401#E66682E052333B55",
        ),
        (
            "motion --id 32 --p-des 0 --v-des 0 --kp 0 --kd 0 --t-ff 0",
            "420#8000800000000800",
        ),
    ];
    for (args, frame) in cases {
        let args = format!("{v3} {args}");
        assert_eq!(encode(&args), format!("{frame}\n"), "rmd encode {args}");
    }
    // V4.4 firmware: the motion-mode torque range is the motor's maximum torque.
    assert_eq!(
        encode(&format!(
            "{v3} --firmware-date 2026042402 --motor-max-torque 60 \
             motion --id 1 --p-des 0 --v-des 0 --kp 0 --kd 0 --t-ff 0"
        )),
        "401#8000800000000800\n"
    );
}

#[test]
fn myactuator_v3_refuses_what_it_does_not_speak() {
    let cases = [
        (
            "--protocol myactuator-v3 multi-torque --amps 1,1,1,1",
            "not part of protocol myactuator-v3",
        ),
        (
            "--protocol myactuator-v3 read-status-3 --id 1",
            "read-status-3 (0x9D) is not a command of protocol myactuator-v3",
        ),
        (
            "--protocol myactuator-v3 torque --id 1 --amps 400",
            "myactuator-v3 takes -327.68..=327.67 A",
        ),
        (
            "--protocol myactuator-v3 --firmware-date 2026042402 \
             motion --id 1 --p-des 0 --v-des 0 --kp 0 --kd 0 --t-ff 0",
            "--motor-max-torque",
        ),
        (
            "--protocol myactuator-v3 motion --id 1 --p-des 13 --v-des 0 --kp 0 --kd 0 --t-ff 0",
            "p_des",
        ),
        (
            "read-model --id 1",
            "read-model (0xB5) is not a command of protocol v1.61",
        ),
        (
            "motion --id 1 --p-des 0 --v-des 0 --kp 0 --kd 0 --t-ff 0",
            "v1.61",
        ),
        ("torque --broadcast --amps 1", "v1.61"),
        (
            "--firmware-date 2026042402 read-status-1 --id 1",
            "--protocol myactuator-v3",
        ),
    ];
    for (args, needle) in cases {
        let stderr = encode_error(args);
        assert!(
            stderr.contains(needle),
            "{args}: {stderr:?} lacks {needle:?}"
        );
    }
}
