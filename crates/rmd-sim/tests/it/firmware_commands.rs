//! Every command of protocol v1.61 against the firmware model: one table-driven test per
//! command. Each row is a script of requests to motor 1 (one per simulated millisecond unless
//! a wait says otherwise) with the exact reply bytes the spec and its reading notes prescribe,
//! worked out by hand in the comments.
//!
//! Defaults used below (see `MotorParams`, `FirmwareParams`): 25 °C ambient (0x19), 48.0 V
//! supply (480 = 0x01E0), 14-bit encoder (16384 counts per turn), PID 100/100/50/40/50/50
//! (0x64 0x64 0x32 0x28 0x32 0x32), acceleration 36000 dps/s (0x00008CA0), gear ratio 9 (motor
//! angle = 9 x output angle).

use core::time::Duration;

use rmd_bus::Timestamp;
use rmd_protocol::{CanFrame, EncoderValue, EncoderWidth, MotorId, PidParams};
use rmd_sim::{ClearErrorReply, FaultRule, PhysicalFault, SimConfig, SimMotorConfig, SimMotors};

enum Expect {
    /// This exact reply (DLC 8, ID 0x141).
    Reply([u8; 8]),
    /// A reply satisfying the check.
    Where(&'static str, fn(&[u8; 8]) -> bool),
    /// No reply: the firmware ignores the request.
    Nothing,
}

enum Step {
    Ask([u8; 8], Expect),
    Wait(u64),
    PowerCycle,
}

use Expect::*;
use Step::*;

fn id1() -> MotorId {
    MotorId::new(1).unwrap()
}

/// Runs `steps` against one motor configured by `setup`.
fn run(
    case: &str,
    setup: impl FnOnce(&mut SimMotorConfig),
    faults: Vec<FaultRule>,
    steps: &[Step],
) {
    let mut config = SimConfig::with_motors(1);
    setup(&mut config.motors[0]);
    config.faults = faults;
    let mut motors = SimMotors::new(&config, Timestamp::ZERO).unwrap();
    let mut t = Timestamp::ZERO;
    for (i, step) in steps.iter().enumerate() {
        match step {
            Wait(ms) => t += Duration::from_millis(*ms),
            PowerCycle => {
                t += Duration::from_millis(1);
                assert!(motors.power_cycle(id1(), t));
            }
            Ask(data, expect) => {
                t += Duration::from_millis(1);
                let frame = CanFrame::with_data(0x141, *data).unwrap();
                let replies: Vec<_> = motors.handle(&frame, t).collect();
                let got = match replies.as_slice() {
                    [] => None,
                    [r] => {
                        assert_eq!(r.frame.id(), 0x141, "{case}, step {i}");
                        assert!(r.at >= t + Duration::from_micros(200), "{case}, step {i}");
                        Some(*r.frame.data8().expect("DLC 8"))
                    }
                    more => panic!("{case}, step {i}: {} replies", more.len()),
                };
                match (expect, got) {
                    (Reply(want), Some(got)) => assert_eq!(
                        got, *want,
                        "{case}, step {i}: reply {got:02X?}, want {want:02X?}"
                    ),
                    (Where(what, check), Some(got)) => {
                        assert!(check(&got), "{case}, step {i}: {got:02X?} is not {what}")
                    }
                    (Nothing, None) => {}
                    (_, got) => panic!("{case}, step {i}: unexpected reply {got:02X?}"),
                }
            }
        }
    }
}

fn defaults(_: &mut SimMotorConfig) {}

fn mounted_quarter_turn(m: &mut SimMotorConfig) {
    m.motor.encoder_mount_offset_turns = 0.25;
}

/// A rotor that cannot turn (huge dry friction), so currents can be read at a known angle.
fn stuck(m: &mut SimMotorConfig) {
    m.motor.coulomb_friction_nm = 1_000.0;
}

fn angle_of(d: &[u8; 8]) -> i64 {
    i64::from_le_bytes([0, d[1], d[2], d[3], d[4], d[5], d[6], d[7]]) >> 8
}

fn speed_of(d: &[u8; 8]) -> i16 {
    i16::from_le_bytes([d[4], d[5]])
}

fn iq_of(d: &[u8; 8]) -> i16 {
    i16::from_le_bytes([d[2], d[3]])
}

const DEFAULT_PID: [u8; 8] = [0x30, 0, 0x64, 0x64, 0x32, 0x28, 0x32, 0x32];
const READ_PID: [u8; 8] = [0x30, 0, 0, 0, 0, 0, 0, 0];
const READ_ACCEL: [u8; 8] = [0x33, 0, 0, 0, 0, 0, 0, 0];
const READ_ENCODER: [u8; 8] = [0x90, 0, 0, 0, 0, 0, 0, 0];
const READ_ANGLE: [u8; 8] = [0x92, 0, 0, 0, 0, 0, 0, 0];
const READ_CIRCLE: [u8; 8] = [0x94, 0, 0, 0, 0, 0, 0, 0];
const STATUS1: [u8; 8] = [0x9A, 0, 0, 0, 0, 0, 0, 0];
const CLEAR: [u8; 8] = [0x9B, 0, 0, 0, 0, 0, 0, 0];
const STATUS2: [u8; 8] = [0x9C, 0, 0, 0, 0, 0, 0, 0];
const STATUS3: [u8; 8] = [0x9D, 0, 0, 0, 0, 0, 0, 0];
const OFF: [u8; 8] = [0x80, 0, 0, 0, 0, 0, 0, 0];
const STOP: [u8; 8] = [0x81, 0, 0, 0, 0, 0, 0, 0];
const RUN: [u8; 8] = [0x88, 0, 0, 0, 0, 0, 0, 0];
/// 0xA1 with iqControl 100 = 1.6 A.
const TORQUE_100: [u8; 8] = [0xA1, 0, 0, 0, 0x64, 0x00, 0, 0];
/// Status 2 at rest, 25 °C, encoder 0: the reply to any control command on a fresh motor.
const AT_REST: [u8; 6] = [0x19, 0, 0, 0, 0, 0];

fn at_rest(code: u8) -> [u8; 8] {
    let mut d = [code, 0, 0, 0, 0, 0, 0, 0];
    d[1..7].copy_from_slice(&AT_REST);
    d
}

#[test]
fn command_0x30_read_pid() {
    run(
        "fresh motor: ROM defaults",
        defaults,
        vec![],
        &[Ask(READ_PID, Reply(DEFAULT_PID))],
    );
    run(
        "reserved request bytes are ignored",
        defaults,
        vec![],
        &[Ask(
            [0x30, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF],
            Reply(DEFAULT_PID),
        )],
    );
    run(
        "configured ROM gains",
        |m| {
            m.firmware.pid = PidParams {
                angle_pid_kp: 1,
                angle_pid_ki: 2,
                speed_pid_kp: 3,
                speed_pid_ki: 4,
                iq_pid_kp: 5,
                iq_pid_ki: 6,
            }
        },
        vec![],
        &[Ask(READ_PID, Reply([0x30, 0, 1, 2, 3, 4, 5, 6]))],
    );
}

#[test]
fn command_0x31_write_pid_ram() {
    let write = [0x31, 0, 1, 2, 3, 4, 5, 6];
    run(
        "echoed, read back, lost at power cycle",
        defaults,
        vec![],
        &[
            Ask(write, Reply(write)),
            Ask(READ_PID, Reply([0x30, 0, 1, 2, 3, 4, 5, 6])),
            PowerCycle,
            Ask(READ_PID, Reply(DEFAULT_PID)),
        ],
    );
}

#[test]
fn command_0x32_write_pid_rom() {
    let write = [0x32, 0, 7, 8, 9, 10, 11, 12];
    run(
        "echoed, in effect at once, kept across a power cycle",
        defaults,
        vec![],
        &[
            Ask(write, Reply(write)),
            Ask(READ_PID, Reply([0x30, 0, 7, 8, 9, 10, 11, 12])),
            PowerCycle,
            Ask(READ_PID, Reply([0x30, 0, 7, 8, 9, 10, 11, 12])),
            // A later RAM write does not touch ROM.
            Ask(
                [0x31, 0, 1, 1, 1, 1, 1, 1],
                Reply([0x31, 0, 1, 1, 1, 1, 1, 1]),
            ),
            PowerCycle,
            Ask(READ_PID, Reply([0x30, 0, 7, 8, 9, 10, 11, 12])),
        ],
    );
}

#[test]
fn command_0x33_read_accel() {
    // Accel is i32 in DATA[4..=7] (reading notes), DATA[1..=3] = 0.
    run(
        "default 36000 dps/s",
        defaults,
        vec![],
        &[Ask(
            READ_ACCEL,
            Reply([0x33, 0, 0, 0, 0xA0, 0x8C, 0x00, 0x00]),
        )],
    );
    run(
        "negative value, two's complement",
        |m| m.firmware.accel = rmd_protocol::Accel::saturating(-5),
        vec![],
        &[Ask(
            READ_ACCEL,
            Reply([0x33, 0, 0, 0, 0xFB, 0xFF, 0xFF, 0xFF]),
        )],
    );
}

#[test]
fn command_0x34_write_accel_ram() {
    let write = [0x34, 0, 0, 0, 0xE8, 0x03, 0, 0]; // 1000 dps/s
    run(
        "echoed, read back, lost at power cycle",
        defaults,
        vec![],
        &[
            Ask(write, Reply(write)),
            Ask(READ_ACCEL, Reply([0x33, 0, 0, 0, 0xE8, 0x03, 0, 0])),
            PowerCycle,
            Ask(READ_ACCEL, Reply([0x33, 0, 0, 0, 0xA0, 0x8C, 0, 0])),
        ],
    );
}

#[test]
fn command_0x90_read_encoder() {
    run(
        "rotor at zero, no offsets",
        defaults,
        vec![],
        &[Ask(READ_ENCODER, Reply([0x90, 0, 0, 0, 0, 0, 0, 0]))],
    );
    // Mounting offset a quarter turn: encoderRaw = 16384 / 4 = 4096 = 0x1000.
    run(
        "raw reading with the mounting offset",
        mounted_quarter_turn,
        vec![],
        &[Ask(
            READ_ENCODER,
            Reply([0x90, 0, 0x00, 0x10, 0x00, 0x10, 0, 0]),
        )],
    );
    // encoder = raw - offset = 4096 - 1000 = 3096 = 0x0C18; offset 1000 = 0x03E8.
    run(
        "offset from ROM applied",
        |m| {
            mounted_quarter_turn(m);
            m.firmware.encoder_offset = EncoderValue::from_raw(1000);
        },
        vec![],
        &[Ask(
            READ_ENCODER,
            Reply([0x90, 0, 0x18, 0x0C, 0x00, 0x10, 0xE8, 0x03]),
        )],
    );
    // 12 bits, half a turn: 2048 = 0x0800.
    run(
        "12-bit encoder",
        |m| {
            m.firmware.encoder_width = EncoderWidth::new(12).unwrap();
            m.motor.encoder_mount_offset_turns = 0.5;
        },
        vec![],
        &[Ask(
            READ_ENCODER,
            Reply([0x90, 0, 0x00, 0x08, 0x00, 0x08, 0, 0]),
        )],
    );
    // 18 bits, a quarter turn: 65536 counts, scaled into 16 bits: 16384 = 0x4000.
    run(
        "18-bit encoder scaled into the u16 field",
        |m| {
            m.firmware.encoder_width = EncoderWidth::new(18).unwrap();
            mounted_quarter_turn(m);
        },
        vec![],
        &[Ask(
            READ_ENCODER,
            Reply([0x90, 0, 0x00, 0x40, 0x00, 0x40, 0, 0]),
        )],
    );
}

#[test]
fn command_0x91_write_encoder_offset() {
    let write_1000 = [0x91, 0, 0, 0, 0, 0, 0xE8, 0x03];
    run(
        "applied at once (RAM), lost at power cycle",
        mounted_quarter_turn,
        vec![],
        &[
            Ask(write_1000, Reply(write_1000)),
            Ask(
                READ_ENCODER,
                Reply([0x90, 0, 0x18, 0x0C, 0x00, 0x10, 0xE8, 0x03]),
            ),
            PowerCycle,
            Ask(READ_ENCODER, Reply([0x90, 0, 0x00, 0x10, 0x00, 0x10, 0, 0])),
        ],
    );
    // 20000 = 0x4E20 does not fit a 14-bit encoder: ignored, no reply, nothing changed.
    run(
        "beyond the encoder width: ignored",
        mounted_quarter_turn,
        vec![],
        &[
            Ask([0x91, 0, 0, 0, 0, 0, 0x20, 0x4E], Nothing),
            Ask(READ_ENCODER, Reply([0x90, 0, 0x00, 0x10, 0x00, 0x10, 0, 0])),
        ],
    );
}

#[test]
fn command_0x19_write_zero_rom() {
    run(
        "replies with the offset written, effective only after a power cycle",
        mounted_quarter_turn,
        vec![],
        &[
            // Current raw position 4096 = 0x1000 becomes the ROM zero.
            Ask(
                [0x19, 0, 0, 0, 0, 0, 0, 0],
                Reply([0x19, 0, 0, 0, 0, 0, 0x00, 0x10]),
            ),
            // Not yet in effect.
            Ask(READ_ENCODER, Reply([0x90, 0, 0x00, 0x10, 0x00, 0x10, 0, 0])),
            PowerCycle,
            Ask(READ_ENCODER, Reply([0x90, 0, 0, 0, 0x00, 0x10, 0x00, 0x10])),
            Ask(READ_ANGLE, Reply([0x92, 0, 0, 0, 0, 0, 0, 0])),
            // A second power cycle keeps it (ROM).
            PowerCycle,
            Ask(READ_ENCODER, Reply([0x90, 0, 0, 0, 0x00, 0x10, 0x00, 0x10])),
        ],
    );
}

#[test]
fn command_0x92_read_multi_turn_angle() {
    run(
        "at zero",
        defaults,
        vec![],
        &[Ask(READ_ANGLE, Reply([0x92, 0, 0, 0, 0, 0, 0, 0]))],
    );
    // Output 100° = motor 900° = 2.5 turns: at power-up the count starts within one turn, so
    // 180.00° = 18000 = 0x4650.
    run(
        "power-up starts within one turn",
        |m| m.initial_output_angle_deg = 100.0,
        vec![],
        &[Ask(READ_ANGLE, Reply([0x92, 0x50, 0x46, 0, 0, 0, 0, 0]))],
    );
    // Output -10° = motor -90°: 270.00° = 27000 = 0x6978.
    run(
        "power-up below zero",
        |m| m.initial_output_angle_deg = -10.0,
        vec![],
        &[Ask(READ_ANGLE, Reply([0x92, 0x78, 0x69, 0, 0, 0, 0, 0]))],
    );
    // Offset 4096 (a quarter turn) at raw 0: the angle is -90.00° = -9000, sent as 56-bit two's
    // complement: 0xFF_FFFF_FFFF_DCD8.
    run(
        "negative, 56-bit two's complement",
        defaults,
        vec![],
        &[
            Ask(
                [0x91, 0, 0, 0, 0, 0, 0x00, 0x10],
                Reply([0x91, 0, 0, 0, 0, 0, 0x00, 0x10]),
            ),
            Ask(
                READ_ANGLE,
                Reply([0x92, 0xD8, 0xDC, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]),
            ),
        ],
    );
    // Accumulates over turns: position 1 to +720° (two motor turns) -> 72000 counts exactly
    // at the target (a count is 2.2 hundredths of a degree: allow one count either side).
    run(
        "accumulates over several turns",
        defaults,
        vec![],
        &[
            Ask(
                [0xA3, 0, 0, 0, 0x40, 0x19, 0x01, 0x00],
                Reply(at_rest(0xA3)),
            ),
            Wait(1_000),
            Ask(
                READ_ANGLE,
                Where("72000 ± 3", |d| (angle_of(d) - 72_000).abs() <= 3),
            ),
        ],
    );
}

#[test]
fn command_0x94_read_single_turn_angle() {
    // Motor 900° -> 180.00° = 18000 = 0x4650 in DATA[6..=7].
    run(
        "within the turn",
        |m| m.initial_output_angle_deg = 100.0,
        vec![],
        &[Ask(READ_CIRCLE, Reply([0x94, 0, 0, 0, 0, 0, 0x50, 0x46]))],
    );
    // Motor -90°: counts up clockwise from the zero and wraps: 270.00° = 27000 = 0x6978.
    run(
        "wraps below zero",
        |m| m.initial_output_angle_deg = -10.0,
        vec![],
        &[Ask(READ_CIRCLE, Reply([0x94, 0, 0, 0, 0, 0, 0x78, 0x69]))],
    );
    // Motor 1°: 16384 / 360 = 45.5 counts, quantised to 45, = 45 x 36000 / 16384 = 98.88
    // hundredths: 98 = 0x62.
    run(
        "quantised to the encoder",
        |m| m.initial_output_angle_deg = 1.0 / 9.0,
        vec![],
        &[Ask(READ_CIRCLE, Reply([0x94, 0, 0, 0, 0, 0, 0x62, 0x00]))],
    );
}

#[test]
fn command_0x9a_read_status_1() {
    run(
        "normal: 25 °C, 48.0 V, no flag",
        defaults,
        vec![],
        &[Ask(STATUS1, Reply([0x9A, 0x19, 0, 0xE0, 0x01, 0, 0, 0x00]))],
    );
    // 24 V supply is below the 36 V threshold: bit 0. 240 = 0xF0.
    run(
        "low voltage",
        |m| m.motor.supply_voltage_v = 24.0,
        vec![],
        &[Ask(STATUS1, Reply([0x9A, 0x19, 0, 0xF0, 0x00, 0, 0, 0x01]))],
    );
    // 90 °C at or above the 80 °C threshold: bit 3. 90 = 0x5A.
    run(
        "over temperature",
        |m| m.motor.ambient_temperature_c = 90.0,
        vec![],
        &[Ask(STATUS1, Reply([0x9A, 0x5A, 0, 0xE0, 0x01, 0, 0, 0x08]))],
    );
    // int8_t: -5 °C = 0xFB.
    run(
        "signed temperature",
        |m| m.motor.ambient_temperature_c = -5.0,
        vec![],
        &[Ask(STATUS1, Reply([0x9A, 0xFB, 0, 0xE0, 0x01, 0, 0, 0x00]))],
    );
}

#[test]
fn command_0x9b_clear_error() {
    run(
        "nothing to clear: status 1 layout, echoed command byte",
        defaults,
        vec![],
        &[Ask(CLEAR, Reply([0x9B, 0x19, 0, 0xE0, 0x01, 0, 0, 0x00]))],
    );
    run(
        "cause still present: the flag stays",
        |m| m.motor.supply_voltage_v = 24.0,
        vec![],
        &[Ask(CLEAR, Reply([0x9B, 0x19, 0, 0xF0, 0x00, 0, 0, 0x01]))],
    );
    run(
        "the spec table's 0x9A command byte, as a quirk",
        |m| m.firmware.clear_error_reply = ClearErrorReply::Status1Code,
        vec![],
        &[Ask(CLEAR, Reply([0x9A, 0x19, 0, 0xE0, 0x01, 0, 0, 0x00]))],
    );
    // Supply at 20 V (200 = 0xC8) for the first 5 ms, then back to 48 V.
    run(
        "latched until cleared once the cause is gone",
        defaults,
        vec![
            FaultRule::new(PhysicalFault::LowVoltage { volts: 20.0 })
                .during(Timestamp::ZERO, Timestamp::from_nanos(5_000_000)),
        ],
        &[
            Ask(STATUS1, Reply([0x9A, 0x19, 0, 0xC8, 0x00, 0, 0, 0x01])),
            Ask(CLEAR, Reply([0x9B, 0x19, 0, 0xC8, 0x00, 0, 0, 0x01])),
            Wait(10),
            Ask(STATUS1, Reply([0x9A, 0x19, 0, 0xE0, 0x01, 0, 0, 0x01])),
            Ask(CLEAR, Reply([0x9B, 0x19, 0, 0xE0, 0x01, 0, 0, 0x00])),
            Ask(STATUS1, Reply([0x9A, 0x19, 0, 0xE0, 0x01, 0, 0, 0x00])),
        ],
    );
}

#[test]
fn command_0x9c_read_status_2() {
    run(
        "at rest",
        defaults,
        vec![],
        &[Ask(STATUS2, Reply([0x9C, 0x19, 0, 0, 0, 0, 0, 0]))],
    );
    run(
        "encoder with offsets",
        mounted_quarter_turn,
        vec![],
        &[Ask(STATUS2, Reply([0x9C, 0x19, 0, 0, 0, 0, 0x00, 0x10]))],
    );
    // 1.6 A commanded; the reply scale is 33/2048 A: 1.6 x 2048 / 33 = 99.3 -> 99 = 0x63.
    run(
        "torque current on the reply scale",
        stuck,
        vec![],
        &[
            Ask(TORQUE_100, Reply(at_rest(0xA1))),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0x63, 0x00, 0, 0, 0, 0])),
        ],
    );
}

#[test]
fn command_0x9d_read_status_3() {
    run(
        "no current",
        defaults,
        vec![],
        &[Ask(STATUS3, Reply([0x9D, 0, 0, 0, 0, 0, 0, 0]))],
    );
    // Rotor held at electrical angle 0, iq = 1.6 A, id = 0: iA = -iq sin(0) = 0,
    // iB = -iq sin(-120°) = 1.3856 A -> x64 = 88.7 -> 89 = 0x0059, iC = -89 = 0xFFA7.
    run(
        "phase currents at a known electrical angle",
        stuck,
        vec![],
        &[
            Ask(TORQUE_100, Reply(at_rest(0xA1))),
            Wait(10),
            Ask(
                STATUS3,
                Reply([0x9D, 0, 0x00, 0x00, 0x59, 0x00, 0xA7, 0xFF]),
            ),
        ],
    );
}

#[test]
fn command_0x80_motor_off() {
    run(
        "echoed; clears the mode: run does not resume it",
        stuck,
        vec![],
        &[
            Ask(TORQUE_100, Reply(at_rest(0xA1))),
            Wait(10),
            Ask(OFF, Reply(OFF)),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0, 0, 0, 0, 0, 0])),
            Ask(RUN, Reply(RUN)),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0, 0, 0, 0, 0, 0])),
        ],
    );
}

#[test]
fn command_0x81_motor_stop() {
    run(
        "echoed; output off, the mode kept for run",
        stuck,
        vec![],
        &[
            Ask(TORQUE_100, Reply(at_rest(0xA1))),
            Wait(10),
            Ask(STOP, Reply(STOP)),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0, 0, 0, 0, 0, 0])),
            Ask(RUN, Reply(RUN)),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0x63, 0x00, 0, 0, 0, 0])),
        ],
    );
}

#[test]
fn command_0x88_motor_run() {
    run(
        "echoed on a fresh motor",
        defaults,
        vec![],
        &[Ask(RUN, Reply(RUN))],
    );
    run(
        "a control command also resumes a stopped motor",
        stuck,
        vec![],
        &[
            Ask(STOP, Reply(STOP)),
            Ask(TORQUE_100, Reply(at_rest(0xA1))),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0x63, 0x00, 0, 0, 0, 0])),
        ],
    );
}

#[test]
fn command_0xa1_torque() {
    // -100 -> -1.6 A -> -99 = 0xFF9D.
    run(
        "negative current",
        stuck,
        vec![],
        &[
            Ask([0xA1, 0, 0, 0, 0x9C, 0xFF, 0, 0], Reply(at_rest(0xA1))),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0x9D, 0xFF, 0, 0, 0, 0])),
        ],
    );
    // Not limited by the max torque current (memo 1): 2000 = 32 A although the limit is 1 A;
    // 32 x 2048 / 33 = 1985.9 -> 1986 = 0x07C2.
    run(
        "full scale, not limited by the max torque current",
        |m| {
            stuck(m);
            m.firmware.max_torque_current_a = 1.0;
        },
        vec![],
        &[
            Ask([0xA1, 0, 0, 0, 0xD0, 0x07, 0, 0], Reply(at_rest(0xA1))),
            Wait(10),
            Ask(STATUS2, Reply([0x9C, 0x19, 0xC2, 0x07, 0, 0, 0, 0])),
        ],
    );
    // 2500 is outside -2000..=2000: not a valid request, ignored.
    run(
        "out of range: ignored",
        defaults,
        vec![],
        &[Ask([0xA1, 0, 0, 0, 0xC4, 0x09, 0, 0], Nothing)],
    );
    // The reply reports the motor's state: after 10 ms of 1.6 A on a free rotor it turns.
    run(
        "reply carries temperature, current, speed, encoder",
        defaults,
        vec![],
        &[
            Ask(TORQUE_100, Reply(at_rest(0xA1))),
            Wait(10),
            Ask(
                TORQUE_100,
                Where("iq 99, positive speed", |d| {
                    d[0] == 0xA1 && d[1] == 0x19 && iq_of(d) == 99 && speed_of(d) > 0
                }),
            ),
        ],
    );
}

#[test]
fn command_0xa2_speed() {
    // 3600 dps = 360000 hundredths = 0x00057E40. With the 36000 dps/s ramp it is reached in
    // 0.1 s; 0.5 s later it holds it to the dps.
    run(
        "reaches and holds the target",
        defaults,
        vec![],
        &[
            Ask(
                [0xA2, 0, 0, 0, 0x40, 0x7E, 0x05, 0x00],
                Reply(at_rest(0xA2)),
            ),
            Wait(500),
            Ask(
                STATUS2,
                Where("3600 ± 1 dps", |d| (speed_of(d) - 3600).abs() <= 1),
            ),
        ],
    );
    // Limited by the max torque current: 0.2 A x 0.2322 N·m/A = 0.046 N·m against 0.04 N·m of
    // dry friction leaves 0.006 N·m: about 1320 dps/s, so after 0.5 s it is far from 3600.
    run(
        "limited by the max torque current",
        |m| m.firmware.max_torque_current_a = 0.2,
        vec![],
        &[
            Ask(
                [0xA2, 0, 0, 0, 0x40, 0x7E, 0x05, 0x00],
                Reply(at_rest(0xA2)),
            ),
            Wait(500),
            Ask(
                STATUS2,
                Where("between 300 and 1000 dps, iq 12", |d| {
                    // 0.2 A x 2048 / 33 = 12.4 -> 12.
                    (300..1000).contains(&speed_of(d)) && iq_of(d) == 12
                }),
            ),
        ],
    );
}

#[test]
fn command_0xa3_position_1() {
    // 90° = 9000 = 0x2328.
    run(
        "moves to the multi-turn target",
        defaults,
        vec![],
        &[
            Ask([0xA3, 0, 0, 0, 0x28, 0x23, 0, 0], Reply(at_rest(0xA3))),
            Wait(500),
            Ask(
                READ_ANGLE,
                Where("9000 ± 3", |d| (angle_of(d) - 9000).abs() <= 3),
            ),
        ],
    );
    run(
        "limited by the max angle",
        |m| m.firmware.max_angle_deg = Some(45.0),
        vec![],
        &[
            Ask([0xA3, 0, 0, 0, 0x28, 0x23, 0, 0], Reply(at_rest(0xA3))),
            Wait(500),
            Ask(
                READ_ANGLE,
                Where("4500 ± 3", |d| (angle_of(d) - 4500).abs() <= 3),
            ),
        ],
    );
    // Limited by the max speed: 600 dps; 360° takes 0.6 s plus the ramps.
    run(
        "limited by the max speed",
        |m| m.firmware.max_speed_dps = 600.0,
        vec![],
        &[
            Ask([0xA3, 0, 0, 0, 0xA0, 0x8C, 0, 0], Reply(at_rest(0xA3))),
            Wait(300),
            Ask(
                STATUS2,
                Where("600 ± 3 dps", |d| (speed_of(d) - 600).abs() <= 3),
            ),
        ],
    );
}

#[test]
fn command_0xa4_position_2() {
    // maxSpeed 360 dps = 0x0168 in DATA[2..=3]; angle 720° = 72000 = 0x00011940 in DATA[4..=7].
    run(
        "speed limit from the frame",
        defaults,
        vec![],
        &[
            Ask(
                [0xA4, 0, 0x68, 0x01, 0x40, 0x19, 0x01, 0x00],
                Reply(at_rest(0xA4)),
            ),
            Wait(1_000),
            Ask(
                STATUS2,
                Where("360 ± 2 dps", |d| (speed_of(d) - 360).abs() <= 2),
            ),
            Wait(2_000),
            Ask(
                READ_ANGLE,
                Where("72000 ± 3", |d| (angle_of(d) - 72_000).abs() <= 3),
            ),
        ],
    );
}

#[test]
fn command_0xa5_position_3() {
    // Single-turn target 90° (0x2328), clockwise (0): +90°.
    run(
        "clockwise",
        defaults,
        vec![],
        &[
            Ask([0xA5, 0x00, 0, 0, 0x28, 0x23, 0, 0], Reply(at_rest(0xA5))),
            Wait(500),
            Ask(
                READ_ANGLE,
                Where("9000 ± 3", |d| (angle_of(d) - 9000).abs() <= 3),
            ),
            Ask(
                READ_CIRCLE,
                Where("9000 ± 3", |d| {
                    (i64::from(u16::from_le_bytes([d[6], d[7]])) - 9000).abs() <= 3
                }),
            ),
        ],
    );
    // Counterclockwise (1) to 90° from 0°: the long way, -270°. (Arrives in 0.2 s; the last
    // count of dry-friction hunting can take most of a second.)
    run(
        "counterclockwise",
        defaults,
        vec![],
        &[
            Ask([0xA5, 0x01, 0, 0, 0x28, 0x23, 0, 0], Reply(at_rest(0xA5))),
            Wait(1_500),
            Ask(
                READ_ANGLE,
                Where("-27000 ± 3", |d| (angle_of(d) + 27_000).abs() <= 3),
            ),
        ],
    );
    run(
        "invalid direction byte: ignored",
        defaults,
        vec![],
        &[Ask([0xA5, 0x02, 0, 0, 0x28, 0x23, 0, 0], Nothing)],
    );
}

#[test]
fn command_0xa6_position_4() {
    // Counterclockwise to 90° at most 360 dps (DATA[2..=3] = 0x0168).
    run(
        "direction and speed limit from the frame",
        defaults,
        vec![],
        &[
            Ask(
                [0xA6, 0x01, 0x68, 0x01, 0x28, 0x23, 0, 0],
                Reply(at_rest(0xA6)),
            ),
            Wait(400),
            Ask(
                STATUS2,
                Where("-360 ± 2 dps", |d| (speed_of(d) + 360).abs() <= 2),
            ),
            Wait(1_000),
            Ask(
                READ_ANGLE,
                Where("-27000 ± 3", |d| (angle_of(d) + 27_000).abs() <= 3),
            ),
        ],
    );
}

#[test]
fn frame_0x280_multi_torque() {
    // Four iqControl values, motors 1..4 answer in ascending id order with the 0xA1 layout.
    let mut config = SimConfig::with_motors(4);
    for m in &mut config.motors {
        stuck(m);
    }
    let mut motors = SimMotors::new(&config, Timestamp::ZERO).unwrap();
    let t = Timestamp::from_nanos(1_000_000);
    // 100, -100, 200, 0.
    let frame = CanFrame::with_data(0x280, [0x64, 0x00, 0x9C, 0xFF, 0xC8, 0x00, 0, 0]).unwrap();
    let replies: Vec<_> = motors.handle(&frame, t).collect();
    let ids: Vec<u16> = replies.iter().map(|r| r.frame.id()).collect();
    assert_eq!(ids, [0x141, 0x142, 0x143, 0x144]);
    assert!(replies.windows(2).all(|w| w[0].at <= w[1].at));
    for r in &replies {
        assert_eq!(r.frame.data(), at_rest(0xA1));
    }
    // 10 ms later each motor carries its own current: 1.6 A -> 99, -1.6 A -> -99,
    // 3.2 A -> 198.6 -> 199, 0.
    let t = t + Duration::from_millis(10);
    let replies: Vec<_> = motors.handle(&frame, t).collect();
    let iqs: Vec<i16> = replies
        .iter()
        .map(|r| iq_of(r.frame.data8().unwrap()))
        .collect();
    assert_eq!(iqs, [99, -99, 199, 0]);

    // Motors 5.. ignore 0x280; absent ids do not answer.
    let mut config = SimConfig::with_motors(0);
    config.motors = [2, 5]
        .iter()
        .map(|&i| SimMotorConfig::new(MotorId::new(i).unwrap()))
        .collect();
    let mut motors = SimMotors::new(&config, Timestamp::ZERO).unwrap();
    let ids: Vec<u16> = motors.handle(&frame, t).map(|r| r.frame.id()).collect();
    assert_eq!(ids, [0x142]);
}

#[test]
fn malformed_frames_are_ignored_and_the_rest_still_handled() {
    let mut motors = SimMotors::new(&SimConfig::with_motors(1), Timestamp::ZERO).unwrap();
    let t = Timestamp::from_nanos(1_000_000);
    for bad in [
        CanFrame::new(0x141, &[0x9C, 0, 0]).unwrap(), // DLC 3
        CanFrame::with_data(0x141, [0x42, 0, 0, 0, 0, 0, 0, 0]).unwrap(), // unknown command
        CanFrame::with_data(0x142, [0x9C, 0, 0, 0, 0, 0, 0, 0]).unwrap(), // no motor 2 here
        CanFrame::with_data(0x7FF, [0; 8]).unwrap(),  // not an RMD ID
        CanFrame::new(0x280, &[1, 2]).unwrap(),       // short 0x280
    ] {
        assert_eq!(motors.handle(&bad, t).count(), 0, "{bad}");
    }
    assert_eq!(motors.ignored_frames(), 5);
    let good = CanFrame::with_data(0x141, STATUS2).unwrap();
    assert_eq!(motors.handle(&good, t).count(), 1);
}

#[test]
fn extreme_settings_never_panic() {
    // Zero and maximal gains, zero and huge limits, huge jitter: whatever the host writes, the
    // firmware keeps running (badly tuned loops may oscillate, but nothing breaks).
    let mut config = SimConfig::with_motors(2);
    config.motors[0].turnaround_jitter = Duration::MAX;
    config.motors[1].turnaround = Duration::MAX;
    let mut motors = SimMotors::new(&config, Timestamp::ZERO).unwrap();
    let mut t = Timestamp::ZERO;
    for pid in [
        [0u8; 6],
        [255; 6],
        [0, 0, 0, 255, 0, 0],
        [255, 0, 0, 0, 255, 255],
    ] {
        for accel in [0i32, -1, 1, i32::MAX] {
            for command in [
                [0xA2, 0, 0, 0, 0x00, 0x00, 0x00, 0x80], // i32::MIN hundredths of dps
                [0xA3, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0x7F],
                [0xA4, 0, 0, 0, 0x00, 0x00, 0x00, 0x80], // max speed 0
                [0xA6, 1, 0xFF, 0xFF, 0x9F, 0x8C, 0, 0],
                [0xA1, 0, 0, 0, 0xD0, 0x07, 0, 0],
            ] {
                for id in [0x141u16, 0x142] {
                    let p = pid;
                    let setup = [
                        [0x31, 0, p[0], p[1], p[2], p[3], p[4], p[5]],
                        {
                            let a = accel.to_le_bytes();
                            [0x34, 0, 0, 0, a[0], a[1], a[2], a[3]]
                        },
                        command,
                    ];
                    for data in setup {
                        t += Duration::from_millis(3);
                        let frame = CanFrame::with_data(id, data).unwrap();
                        for reply in motors.handle(&frame, t) {
                            assert_eq!(reply.frame.dlc(), 8);
                        }
                    }
                }
            }
        }
    }
    let s = motors.snapshot_at(id1(), t).unwrap();
    assert!(s.motor_angle_deg.is_finite() && s.current_a.is_finite());
}
