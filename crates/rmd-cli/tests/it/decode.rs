//! `rmd decode`: every input format, direction pairing, forced modes, bad lines.

use assert_cmd::Command;
use serde_json::{Value, json};

struct Run {
    code: Option<i32>,
    objects: Vec<Value>,
    stderr: Vec<String>,
}

/// Runs `rmd decode ARGS` with `input` on stdin.
fn decode(args: &[&str], input: &str) -> Run {
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .arg("decode")
        .args(args)
        .write_stdin(input)
        .output()
        .unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    Run {
        code: out.status.code(),
        objects: stdout
            .lines()
            .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
            .collect(),
        stderr: String::from_utf8(out.stderr)
            .unwrap()
            .lines()
            .map(String::from)
            .collect(),
    }
}

fn ok(args: &[&str], input: &str) -> Vec<Value> {
    let run = decode(args, input);
    assert_eq!(run.code, Some(0), "stderr: {:?}", run.stderr);
    assert!(run.stderr.is_empty());
    run.objects
}

#[test]
fn compact_form_request_and_reply() {
    let out = ok(&[], "141#A100000064000000\n141#A11900080A00FF3F\n");
    assert_eq!(
        out[0],
        json!({"id": 1, "can_id": "0x141", "direction": "request", "command": "torque",
               "iq_control": 100, "iq_control_amps": 1.6})
    );
    assert_eq!(
        out[1],
        json!({"id": 1, "can_id": "0x141", "direction": "reply", "command": "torque",
               "temperature": 25, "temperature_celsius": 25.0, "iq": 2048, "iq_amps": 33.0,
               "speed": 10, "speed_dps": 10.0, "encoder": 16383,
               "encoder_degrees": 16383.0 * 360.0 / 16384.0})
    );
}

#[test]
fn log_form_with_multi_torque_exchange() {
    let input = "\
(1700000000.010000) can0 280#64009CFF0000D007
(1700000000.010120) can0 141#A11E3E000A000010
(1700000000.010240) can0 142#A11FC2FFF6FF0020
(1700000000.010360) can0 143#A120000000000030
(1700000000.010480) can0 144#A121E0076400FF3F
";
    let out = ok(&[], input);
    assert_eq!(out.len(), 5);
    assert_eq!(
        out[0],
        json!({"timestamp": 1700000000.01, "interface": "can0", "can_id": "0x280",
               "direction": "request", "command": "multi-torque",
               "iq_control": [100, -100, 0, 2000], "iq_control_amps": [1.6, -1.6, 0.0, 32.0]})
    );
    for (i, o) in out[1..].iter().enumerate() {
        assert_eq!(o["id"], json!(i + 1));
        assert_eq!(o["direction"], "reply");
        assert_eq!(o["command"], "torque");
        assert_eq!(o["interface"], "can0");
    }
    assert_eq!(out[1]["iq"], 62);
    assert_eq!(out[2]["speed_dps"], -10.0);
    assert_eq!(out[4]["iq"], 2016);
}

#[test]
fn default_text_form() {
    let input =
        "  can0  141   [8]  9A 00 00 00 00 00 00 00\n  can0  141   [8]  9A F6 00 E0 01 00 00 09\n";
    let out = ok(&[], input);
    assert_eq!(out[0]["direction"], "request");
    assert_eq!(out[0]["command"], "read-status-1");
    assert_eq!(
        out[1],
        json!({"interface": "can0", "id": 1, "can_id": "0x141", "direction": "reply",
               "command": "read-status-1", "temperature": -10, "temperature_celsius": -10.0,
               "voltage": 480, "voltage_volts": 48.0, "error_state": 9,
               "low_voltage": true, "over_temperature": true})
    );
}

#[test]
fn direction_markers_decide() {
    // Default text with -x: a TX torque whose reply is lost, then another TX, then its RX reply.
    let input = "\
  can0  TX - -  141   [8]  A1 00 00 00 64 00 00 00
  can0  TX - -  141   [8]  A1 00 00 00 64 00 00 00
  can0  RX - -  141   [8]  A1 19 00 08 0A 00 FF 3F
";
    let out = ok(&[], input);
    let dirs: Vec<&str> = out
        .iter()
        .map(|o| o["direction"].as_str().unwrap())
        .collect();
    assert_eq!(dirs, ["request", "request", "reply"]);
    // Without markers, pairing would take the second frame for the reply of the first.
    let unmarked = "141#A100000064000000\n141#A100000064000000\n";
    let out = ok(&[], unmarked);
    assert_eq!(out[1]["direction"], "reply");
    // -L lines with -x markers (T / R).
    let input = "(1.000000) can0 142#9C00000000000000 T\n(1.000150) can0 142#9C2000FC0A000020 R\n";
    let out = ok(&[], input);
    assert_eq!(out[0]["direction"], "request");
    assert_eq!(out[1]["direction"], "reply");
    assert_eq!(out[1]["iq_amps"], -16.5);
}

#[test]
fn clear_error_answered_with_status1_byte() {
    let out = ok(&[], "143#9B00000000000000\n143#9A2100F000000000\n");
    assert_eq!(out[1]["direction"], "reply");
    assert_eq!(out[1]["command"], "clear-error");
    assert_eq!(out[1]["voltage_volts"], 24.0);
}

#[test]
fn every_reply_layout_has_its_fields() {
    let input = "\
141#3000000000000000
141#30006432281E140A
141#3300000000000000
141#3300000010270000
141#9000000000000000
141#9000E8038813A00F
141#1900000000000000
141#190000000000FF3F
141#9200000000000000
141#92606CFFFFFFFFFF
141#9400000000000000
141#9400000000007869
141#9D00000000000000
141#9D004000E0FFE0FF
";
    let out = ok(&[], input);
    assert_eq!(out[1]["angle_pid_kp"], 100);
    assert_eq!(out[1]["iq_pid_ki"], 10);
    assert_eq!(out[3]["accel"], 10000);
    assert_eq!(out[3]["accel_dps_per_s"], 10000.0);
    assert_eq!(out[5]["encoder"], 1000);
    assert_eq!(out[5]["encoder_raw"], 5000);
    assert_eq!(out[5]["encoder_offset"], 4000);
    assert_eq!(out[7]["encoder_offset"], 16383);
    // 0xFFFFFFFFFF6C60 sign-extended = -37792.
    assert_eq!(out[9]["motor_angle"], -37792);
    assert_eq!(out[9]["motor_angle_degrees"], -377.92);
    assert_eq!(out[11]["circle_angle_degrees"], 270.0);
    assert_eq!(out[13]["i_a_amps"], 1.0);
    assert_eq!(out[13]["i_c"], -32);
    for o in out.iter().skip(1).step_by(2) {
        assert_eq!(o["direction"], "reply");
    }
}

#[test]
fn request_fields() {
    let input = "\
141#A50100009F8C0000
141#A600680128230000
141#A400F40150460000
141#A2000000A08C0000
141#9100000000003412
";
    let out = ok(&["--as", "request"], input);
    assert_eq!(out[0]["spin_direction"], 1);
    assert_eq!(out[0]["spin_direction_name"], "ccw");
    assert_eq!(out[0]["angle_control"], 35999);
    assert_eq!(out[1]["max_speed"], 360);
    assert_eq!(out[1]["angle_control_degrees"], 90.0);
    assert_eq!(out[2]["angle_control"], 18000);
    assert_eq!(out[3]["speed_control_dps"], 360.0);
    assert_eq!(out[4]["encoder_offset"], 0x1234);
}

#[test]
fn forced_modes() {
    let frame = "141#9C00000000000000\n";
    assert!(
        ok(&["--as", "reply"], &frame.repeat(2))
            .iter()
            .all(|o| o["direction"] == "reply")
    );
    assert!(
        ok(&["--as", "request"], &frame.repeat(2))
            .iter()
            .all(|o| o["direction"] == "request")
    );
}

#[test]
fn bad_lines_are_reported_and_the_rest_decoded() {
    let input = "\
141#9C00000000000000
this is not a frame
141#9C000000000000
123#9C00000000000000

141#5500000000000000
141#A1000000D1070000
141#9C00000000000000
280#64009CFF
can0  141   [8]  9C 00
141#9C2000FC0A000020
";
    let run = decode(&[], input);
    assert_eq!(run.code, Some(1));
    assert_eq!(
        run.stderr,
        [
            "line 2: not a candump line: expected `ID#DATA`, `(time) interface ID#DATA` or `interface ID [N] DATA`",
            "line 3: CAN ID 0x141: DLC 7, every RMD frame has DLC 8",
            "line 4: CAN ID 0x123 is not an RMD ID (0x141..=0x160 or 0x280)",
            "line 6: CAN ID 0x141: unknown command byte 0x55",
            "line 7: iq_control 2001 is out of range -2000..=2000",
            "line 9: CAN ID 0x280: DLC 4, every RMD frame has DLC 8",
            "line 10: length [8] but 2 data bytes",
        ]
    );
    // Decoded: lines 1, 8 and 11. Line 3 was taken for line 1's reply (same ID and command) and
    // failed; line 9's 0x280, though too short, leaves 0xA1 pending on 0x141..=0x144, so the
    // 0x9C of line 11 is a new request.
    let summary: Vec<(String, String)> = run
        .objects
        .iter()
        .map(|o| {
            (
                o["command"].as_str().unwrap().to_string(),
                o["direction"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    let request = ("read-status-2".to_string(), "request".to_string());
    assert_eq!(summary, [request.clone(), request.clone(), request]);
}

#[test]
fn reply_values_out_of_range_and_encoder_width() {
    let run = decode(
        &["--as", "reply"],
        "141#A100010800000000\n141#9C00000000000040\n",
    );
    assert_eq!(run.code, Some(1));
    assert_eq!(
        run.stderr,
        [
            "line 1: iq 2049 is out of range -2048..=2048",
            "line 2: encoder 16384 is out of range 0..=16383 for a 14-bit encoder (see --encoder-bits)",
        ]
    );
    // Both frames still print, without the bad field.
    assert_eq!(run.objects.len(), 2);
    assert!(run.objects[0].get("iq").is_none());
    assert!(run.objects[1].get("encoder").is_none());
    assert_eq!(run.objects[1]["iq"], 0);
    let out = ok(
        &["--as", "reply", "--encoder-bits", "16"],
        "141#9C00000000000040\n",
    );
    assert_eq!(out[0]["encoder"], 16384);
    assert_eq!(out[0]["encoder_degrees"], 90.0);
}

#[test]
fn a_reply_with_a_field_out_of_range_keeps_every_other_field() {
    // Query, then a 0x9C reply with iq = 0x0900 = 2304 (beyond ±2048): 30 °C, -10 dps,
    // encoder 4096. Then a whole-frame error (unknown command byte) and a good reply.
    let input = "\
(1.000000) can0 141#9C00000000000000
(1.000200) can0 141#9C1E0009F6FF0010
(1.000400) can0 141#5500000000000000
(1.000600) can0 142#A11E00000A000000
";
    let run = decode(&[], input);
    assert_eq!(run.code, Some(1), "{:?}", run.stderr);
    assert_eq!(
        run.stderr,
        [
            "line 2: iq 2304 is out of range -2048..=2048",
            "line 3: CAN ID 0x141: unknown command byte 0x55",
        ]
    );
    assert_eq!(run.objects.len(), 3);
    assert_eq!(
        run.objects[1],
        json!({"timestamp": 1.0002, "interface": "can0", "id": 1, "can_id": "0x141",
               "direction": "reply", "command": "read-status-2",
               "temperature": 30, "temperature_celsius": 30.0,
               "speed": -10, "speed_dps": -10.0,
               "encoder": 4096, "encoder_degrees": 90.0,
               "errors": [{"field": "iq", "raw": 2304,
                           "error": "iq 2304 is out of range -2048..=2048"}]})
    );
    // A good frame has no `errors` key; the frame after the bad one decodes as usual.
    assert!(run.objects[0].get("errors").is_none());
    assert_eq!(run.objects[2]["iq_control"], 10);
    // v1.61's single-turn angle beyond 35999: the frame prints, the angle is named.
    let run = decode(&["--as", "reply"], "143#940000000000A08C\n");
    assert_eq!(run.code, Some(1));
    assert_eq!(
        run.stderr,
        ["line 1: circle_angle 36000 is out of range 0..=35999"]
    );
    assert_eq!(run.objects[0]["command"], "read-single-turn-angle");
    assert_eq!(
        run.objects[0]["errors"][0],
        json!({"field": "circle_angle", "raw": 36000,
               "error": "circle_angle 36000 is out of range 0..=35999"})
    );
}

fn directions(objects: &[Value]) -> Vec<&str> {
    objects
        .iter()
        .map(|o| o["direction"].as_str().unwrap())
        .collect()
}

#[test]
fn a_repeated_query_is_another_request_not_its_reply() {
    // Two programs query motor 1 on a shared bus; one reply comes back.
    let input = "\
(1.000000) can0 141#9C00000000000000 R
(1.000050) can0 141#9C00000000000000 R
(1.000200) can0 141#9C1E3E000A000010 R
";
    let out = ok(&[], input);
    assert_eq!(directions(&out), ["request", "request", "reply"]);
    assert_eq!(out[2]["temperature_celsius"], 30.0);
    assert_eq!(out[2]["speed_dps"], 10.0);
    // The same without markers, and for status 1.
    let out = ok(
        &[],
        "141#9A00000000000000\n141#9A00000000000000\n141#9A1E00E001000000\n",
    );
    assert_eq!(directions(&out), ["request", "request", "reply"]);
    assert_eq!(out[2]["voltage_volts"], 48.0);
    // A control command's echo is its reply even when identical (0x80 answers with 0x80).
    let out = ok(&[], "141#8000000000000000\n141#8000000000000000\n");
    assert_eq!(directions(&out), ["request", "reply"]);
}

#[test]
fn direction_markers_win_over_the_repeat_rule() {
    // A log from the sending host: TX request, then an RX frame identical to it. The markers say
    // it is the motor's reply, an all-zero one.
    let input = "\
(1.000000) can0 142#9D00000000000000 T
(1.000200) can0 142#9D00000000000000 R
(1.000300) can0 142#9D00000000000000 T
(1.000500) can0 142#9D00400000000000 T
";
    let out = ok(&[], input);
    assert_eq!(directions(&out), ["request", "reply", "request", "request"]);
    assert_eq!(out[1]["i_a_amps"], 0.0);
}

#[test]
fn all_zero_replies_of_a_motor_at_rest_pair_by_what_follows() {
    // `rmd status` of a motor at rest, recorded by a listen-only logger: 0x9D, 0x90, 0x92 and
    // 0x94 are answered with all zeros, frames identical to their requests. What follows each
    // pair on the ID (another command) says the second frame was the reply.
    let input = "\
(1.000000) can0 141#9A00000000000000 R
(1.000200) can0 141#9A1900E001000000 R
(1.000400) can0 141#9D00000000000000 R
(1.000500) can0 142#9C00000000000000 R
(1.000600) can0 141#9D00000000000000 R
(1.000700) can0 142#9C1E3E000A000010 R
(1.000800) can0 141#9000000000000000 R
(1.001000) can0 141#9000000000000000 R
(1.001200) can0 141#9200000000000000 R
(1.001400) can0 141#9200000000000000 R
";
    let out = ok(&[], input);
    assert_eq!(
        directions(&out),
        [
            "request", "reply", "request", "request", "reply", "reply", "request", "reply",
            "request", "reply"
        ]
    );
    // Input order is kept while the 0x9D pair waits for what follows it.
    let lines: Vec<f64> = out
        .iter()
        .map(|o| o["timestamp"].as_f64().unwrap())
        .collect();
    assert!(lines.windows(2).all(|w| w[0] < w[1]), "{lines:?}");
    assert_eq!(out[4]["command"], "read-status-3");
    assert_eq!(out[4]["i_a_amps"], 0.0);
    assert_eq!(out[9]["motor_angle_degrees"], 0.0);
}

#[test]
fn the_ambiguity_left_reads_as_documented() {
    // docs/cli.md: query, all-zero reply, query, reply with data on one ID reads as three
    // requests and a reply (markers from the sending host tell them apart).
    let input =
        "142#9D00000000000000\n142#9D00000000000000\n142#9D00000000000000\n142#9D00400000000000\n";
    let out = ok(&[], input);
    assert_eq!(directions(&out), ["request", "request", "request", "reply"]);
    let marked = "\
(1.0) can0 142#9D00000000000000 T
(1.1) can0 142#9D00000000000000 R
(1.2) can0 142#9D00000000000000 T
(1.3) can0 142#9D00400000000000 R
";
    assert_eq!(
        directions(&ok(&[], marked)),
        ["request", "reply", "request", "reply"]
    );
}

#[test]
fn a_pair_is_held_at_most_256_lines() {
    // A query and its all-zero copy on 0x141, then 300 frames of motor 2: the pair is decided
    // without its follower (request, reply) and every line still comes out, in order.
    let mut input = String::from("141#9D00000000000000\n141#9D00000000000000\n");
    for _ in 0..150 {
        input.push_str("142#9C00000000000000\n142#9C1E3E000A000010\n");
    }
    input.push_str("141#9D00400000000000\n");
    let out = ok(&[], &input);
    assert_eq!(out.len(), 303);
    assert_eq!(
        directions(&out[..4]),
        ["request", "reply", "request", "reply"]
    );
    // Nothing was pending on 0x141 any more: the last frame is a request.
    assert_eq!(out[302]["direction"], "request");
}

#[test]
fn lk_tech_frames_with_protocol_and_series() {
    // Issue 14's capture: 48.7 V in DATA[2..=3] at 0.01 V.
    let capture = "141#9A00000000000000\n141#9A1E061300000000\n";
    let lk = ok(&["--protocol", "lk-v2.3x", "--lk-series", "mf"], capture);
    assert_eq!(directions(&lk), ["request", "reply"]);
    assert_eq!(
        lk[1],
        json!({"id": 1, "can_id": "0x141", "direction": "reply", "command": "read-status-1",
               "temperature": 30, "temperature_celsius": 30.0,
               "voltage": 4870, "voltage_volts": 48.7,
               "bus_current": 0, "bus_current_amps": 0.0,
               "motor_state": 0, "motor_state_name": "on",
               "error_state": 0, "low_voltage": false, "over_temperature": false})
    );
    // The same frame read as v1.61: 1.9 V (the trap of issue 14).
    assert_eq!(ok(&[], capture)[1]["voltage_volts"], 1.9);
    // Torque: raw 1024 is 8.25 A on an MF motor, 16.5 A on an MG one, 16.384 A in v1.61; 2048
    // is in LK's range only.
    let torque = "141#A100000000040000\n";
    let amps = |args: &[&str]| ok(args, torque)[0]["iq_control_amps"].as_f64().unwrap();
    assert_eq!(amps(&["--protocol", "lk-v2.3x", "--lk-series", "mf"]), 8.25);
    assert_eq!(amps(&["--protocol", "lk-v2.3x", "--lk-series", "mg"]), 16.5);
    assert!((amps(&[]) - 16.384).abs() < 1e-12);
    let full = "141#A100000000080000\n";
    let out = ok(&["--protocol", "lk-v2.3x", "--lk-series", "mf"], full);
    assert_eq!(out[0]["iq_control"], 2048);
    assert_eq!(out[0]["iq_control_amps"], 16.5);
    let run = decode(&[], full);
    assert_eq!(run.code, Some(1));
    assert_eq!(
        run.stderr,
        ["line 1: iq_control 2048 is out of range -2000..=2000"]
    );
    // The reply's iq in the series' scale, and LK's u32 single-turn angle (900° on a geared
    // motor) that v1.61 would read as 0.
    let input = "\
141#A100000000040000
141#A11E00FC00000000
141#9400000000000000
141#9400000090CA0100
";
    let out = ok(&["--protocol", "lk-v2.3x", "--lk-series", "mf"], input);
    assert_eq!(out[1]["iq"], -1024);
    assert_eq!(out[1]["iq_amps"], -8.25);
    assert_eq!(out[3]["circle_angle"], 117_392);
    assert_eq!(out[3]["circle_angle_degrees"], 1173.92);
    // The 0x280 frame in the MG scale.
    let out = ok(
        &["--protocol", "lk-v2.3x", "--lk-series", "mg"],
        "280#000800F800000004\n",
    );
    assert_eq!(out[0]["iq_control_amps"], json!([33.0, -33.0, 0.0, 16.5]));
}

#[test]
fn protocol_options_are_checked() {
    let run = decode(&["--protocol", "lk-v2.3x"], "");
    assert_eq!(run.code, Some(2));
    assert!(run.stderr[0].contains("--lk-series mf"), "{:?}", run.stderr);
    let run = decode(&["--lk-series", "mg"], "");
    assert_eq!(run.code, Some(2));
    assert!(
        run.stderr[0].contains("add --protocol lk-v2.3x"),
        "{:?}",
        run.stderr
    );
    let run = decode(&["--firmware-date", "2026042402"], "");
    assert_eq!(run.code, Some(2));
    assert!(
        run.stderr[0].contains("add --protocol myactuator-v3"),
        "{:?}",
        run.stderr
    );
}

/// MyActuator V3 (V4.3 / V4.4 manuals): replies on `0x240 + id` in SI units, from the manuals'
/// own example frames.
#[test]
fn myactuator_v3_frames_in_si_units() {
    let input = "\
141#A100000064000000
241#A13264001E000001
241#9A320001E5010400
241#9C326400F4012D00
241#B20000002E893401
241#B501015838533256
241#9400000000004C1D
401#E66682E052333B55
501#01E66682EB550000
280#8000000000000000
241#8000000000000000
";
    let out = ok(&["--protocol", "myactuator-v3"], input);
    assert_eq!(out.len(), 11);
    // V4.3 §2.19: 0.01 A per LSB.
    assert_eq!(out[0]["direction"], "request");
    assert_eq!(out[0]["iq_control_amps"], 1.0);
    // Its reply: status 2 with the output shaft's speed and angle.
    assert_eq!(out[1]["direction"], "reply");
    assert_eq!(out[1]["can_id"], "0x241");
    assert_eq!(out[1]["iq"], 100);
    assert_eq!(out[1]["iq_amps"], 1.0);
    assert_eq!(out[1]["speed_dps"], 30.0);
    assert_eq!(out[1]["output_angle_degrees"], 256.0);
    // V4.3 §2.14: 50 °C, brake released, 48.5 V, low-voltage flag.
    assert_eq!(out[2]["temperature_celsius"], 50.0);
    assert_eq!(out[2]["brake_released"], true);
    assert_eq!(out[2]["voltage_volts"], 48.5);
    assert_eq!(out[2]["error_names"], json!(["low_voltage"]));
    // V4.3 §2.15: 50 °C, 1 A, 500 dps, 45 degrees.
    assert_eq!(out[3]["iq_amps"], 1.0);
    assert_eq!(out[3]["speed_dps"], 500.0);
    assert_eq!(out[3]["output_angle_degrees"], 45.0);
    // V4.3 §2.30: firmware 20220206; V4.4 §2.34: model part 1.
    assert_eq!(out[4]["firmware_date"], 20220206);
    assert_eq!(out[5]["model"], "X8S2V");
    // V4.3 §2.13: the single-turn angle, u16 0.01 degree in DATA[6..=7].
    assert_eq!(out[6]["circle_angle_degrees"], 75.0);
    // V4.3 §5.4: the motion-mode command and its reply.
    assert_eq!(out[7]["command"], "motion");
    assert_eq!(out[7]["p_des"], 0xE666);
    assert!((out[7]["p_des_rad"].as_f64().unwrap() - 10.0).abs() < 1e-3);
    assert_eq!(out[8]["direction"], "reply");
    assert!((out[8]["t_nm"].as_f64().unwrap() - 10.004).abs() < 1e-3);
    // V4.3 §3: one command for every motor, answered by each on its own 0x240 + id.
    assert_eq!(out[9]["broadcast"], true);
    assert_eq!(out[10]["command"], "motor-off");

    // V4.4 firmware: 0x94 is an i32 in DATA[4..=7] (V4.4 §2.12: 75 degrees).
    let out = ok(
        &[
            "--protocol",
            "myactuator-v3",
            "--firmware-date",
            "2026042402",
        ],
        "241#940000004C1D0000\n",
    );
    assert_eq!(out[0]["circle_angle_degrees"], 75.0);
}

/// The peak resident memory of a running process, from /proc (kB).
fn peak_rss_kb(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .unwrap_or_else(|| panic!("no VmHWM in {status}"));
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

#[test]
fn an_endless_line_is_an_error_in_bounded_memory() {
    use std::io::{Read, Write};
    use std::process::{Command as Std, Stdio};
    let mut child = Std::new(env!("CARGO_BIN_EXE_rmd"))
        .arg("decode")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    // 100 MiB without a newline (what `rmd decode </dev/zero` reads), then a good line.
    let chunk = vec![0u8; 1 << 20];
    for _ in 0..100 {
        stdin.write_all(&chunk).unwrap();
    }
    stdin.write_all(b"\n141#9C00000000000000\n").unwrap();
    stdin.flush().unwrap();
    // Still running (stdin open): its peak so far covers the whole long line.
    let peak_kb = peak_rss_kb(child.id());
    drop(stdin);
    let mut stdout = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(peak_kb < 64 * 1024, "peak RSS {peak_kb} kB");
    assert_eq!(status.code(), Some(1));
    assert_eq!(
        stderr,
        "line 1: longer than 4096 bytes, not a candump line (skipped to the next newline)\n"
    );
    let objects: Vec<Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(objects.len(), 1);
    assert_eq!(objects[0]["command"], "read-status-2");
}

#[test]
fn a_long_line_among_short_ones_is_that_lines_error() {
    let long = format!("141#9C{}\n", "0".repeat(5000));
    let input = format!("141#9C00000000000000\n{long}141#9C1E3E000A000010\n");
    let run = decode(&[], &input);
    assert_eq!(run.code, Some(1));
    assert_eq!(
        run.stderr,
        ["line 2: longer than 4096 bytes, not a candump line (skipped to the next newline)"]
    );
    assert_eq!(directions(&run.objects), ["request", "reply"]);
}

#[test]
fn reads_a_file_and_reports_a_missing_one() {
    let dir = std::env::temp_dir().join(format!("rmd-decode-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("in.log");
    std::fs::write(&path, "141#9C00000000000000\n").unwrap();
    let run = decode(&[path.to_str().unwrap()], "");
    assert_eq!(run.code, Some(0));
    assert_eq!(run.objects.len(), 1);
    let missing = dir.join("missing.log");
    let run = decode(&[missing.to_str().unwrap()], "");
    assert_eq!(run.code, Some(1));
    assert!(run.objects.is_empty());
    assert_eq!(run.stderr.len(), 1);
    assert!(
        run.stderr[0].starts_with("error: cannot read "),
        "{:?}",
        run.stderr
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sample_log_decodes_cleanly() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/sample-leg.log");
    let run = decode(&[path], "");
    assert_eq!(run.code, Some(0), "{:?}", run.stderr);
    let lines = std::fs::read_to_string(path).unwrap().lines().count();
    assert_eq!(run.objects.len(), lines);
    // Every 0x280 is followed by four torque replies from motors 1..=4.
    for (i, o) in run.objects.iter().enumerate() {
        if o["command"] == "multi-torque" {
            for k in 1..=4 {
                let r = &run.objects[i + k];
                assert_eq!(
                    (r["id"].as_u64(), r["direction"].as_str()),
                    (Some(k as u64), Some("reply"))
                );
            }
        }
    }
    assert_eq!(
        run.objects
            .iter()
            .filter(|o| o["command"] == "multi-torque")
            .count(),
        3
    );
}
