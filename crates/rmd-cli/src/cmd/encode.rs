//! `rmd encode <COMMAND> --id <1..32> [FIELD FLAGS]`: one command as a frame in candump's compact
//! form (`141#A100000064000000`).
//!
//! Field flags are the spec's variable names in kebab-case and take RAW integers; `--amps`,
//! `--dps` and `--deg` are physical-unit alternatives. Out-of-range or missing values exit
//! non-zero with one line on stderr and nothing on stdout.
//!
//! `--protocol lk-v2.3x --lk-series mf|mg` encodes for LK-TECH motors: only the torque current of
//! `torque` (0xA1) and `multi-torque` (0x280) differs (±2048 raw, 16.5/2048 A per LSB on MF,
//! 33/2048 A on MG, instead of v1.61's ±2000 at 32/2000 A); every other frame is the same.

use std::process::ExitCode;

use clap::{ArgGroup, Args, Subcommand, ValueEnum};
use rmd_protocol::{
    Accel, AngleControl, CanFrame, Dialect, DialectRequest, EncoderWidth, MaxSpeed, MotorId,
    PidParams, Request, ScaledCurrent, ScaledMultiTorque, SingleTurnAngle, SpeedControl,
    SpinDirection, encode_request_with,
};

use crate::args::bus::ProtocolArgs;
use crate::args::parse;
use crate::output::outln;
use crate::output::report;

/// Arguments of `rmd encode`.
#[derive(Args, Debug)]
pub(crate) struct EncodeArgs {
    #[command(subcommand)]
    command: EncodeCommand,
    #[command(flatten)]
    protocol: ProtocolArgs,
}

/// The motor a single-motor command goes to.
#[derive(Args, Copy, Clone, Debug)]
struct Target {
    /// Motor id, 1..=32 (CAN ID 0x140 + id).
    #[arg(long, value_parser = parse::motor_id)]
    id: MotorId,
}

#[derive(Args, Debug)]
struct PidArgs {
    #[command(flatten)]
    target: Target,
    /// Position loop Kp (anglePidKp), 0..=255.
    #[arg(long)]
    angle_pid_kp: u8,
    /// Position loop Ki (anglePidKi), 0..=255.
    #[arg(long)]
    angle_pid_ki: u8,
    /// Speed loop Kp (speedPidKp), 0..=255.
    #[arg(long)]
    speed_pid_kp: u8,
    /// Speed loop Ki (speedPidKi), 0..=255.
    #[arg(long)]
    speed_pid_ki: u8,
    /// Torque loop Kp (iqPidKp), 0..=255.
    #[arg(long)]
    iq_pid_kp: u8,
    /// Torque loop Ki (iqPidKi), 0..=255.
    #[arg(long)]
    iq_pid_ki: u8,
}

impl PidArgs {
    fn params(&self) -> PidParams {
        PidParams {
            angle_pid_kp: self.angle_pid_kp,
            angle_pid_ki: self.angle_pid_ki,
            speed_pid_kp: self.speed_pid_kp,
            speed_pid_ki: self.speed_pid_ki,
            iq_pid_kp: self.iq_pid_kp,
            iq_pid_ki: self.iq_pid_ki,
        }
    }
}

#[derive(Args, Debug)]
struct AccelArgs {
    #[command(flatten)]
    target: Target,
    /// Acceleration (Accel), i32, 1 dps/s per LSB.
    #[arg(long, value_parser = parse::accel, allow_hyphen_values = true)]
    accel: Accel,
}

#[derive(Args, Debug)]
struct EncoderOffsetArgs {
    #[command(flatten)]
    target: Target,
    /// Encoder offset (encoderOffset), 0..=2^bits-1.
    #[arg(long, allow_hyphen_values = true)]
    encoder_offset: i64,
    /// Width of the motor's encoder in bits (12..=18; the spec's is 14).
    #[arg(long, value_parser = parse::encoder_width, default_value = "14")]
    encoder_bits: EncoderWidth,
}

#[derive(Args, Debug)]
#[command(group(ArgGroup::new("current").required(true).args(["iq_control", "amps"])))]
struct TorqueArgs {
    #[command(flatten)]
    target: Target,
    /// Torque current (iqControl), raw: -2000..=2000 at 32/2000 A per LSB in v1.61;
    /// -2048..=2048 at 16.5/2048 A (LK MF) or 33/2048 A (LK MG) per LSB with --protocol
    /// lk-v2.3x.
    #[arg(long, value_parser = parse::raw_int, allow_hyphen_values = true)]
    iq_control: Option<i64>,
    /// Torque current in amperes, rounded to the protocol's step: -32..=32 A in steps of
    /// 0.016 A (32/2000) in v1.61; ±16.5 A in steps of 16.5/2048 A (LK MF) or ±33 A in steps of
    /// 33/2048 A (LK MG) with --protocol lk-v2.3x.
    #[arg(long, value_parser = parse::number, allow_hyphen_values = true)]
    amps: Option<f64>,
}

#[derive(Args, Debug)]
#[command(group(ArgGroup::new("speed").required(true).args(["speed_control", "dps"])))]
struct SpeedArgs {
    #[command(flatten)]
    target: Target,
    /// Speed (speedControl), i32, 0.01 dps per LSB.
    #[arg(long, value_parser = parse::speed_control, allow_hyphen_values = true)]
    speed_control: Option<SpeedControl>,
    /// Speed in degrees per second (rounded to 0.01 dps).
    #[arg(long, value_parser = parse::speed_dps, allow_hyphen_values = true)]
    dps: Option<SpeedControl>,
}

/// A multi-turn target angle, raw or in degrees.
#[derive(Args, Debug)]
#[command(group(ArgGroup::new("angle").required(true).args(["angle_control", "deg"])))]
struct MultiTurnAngle {
    /// Target angle (angleControl), i32, 0.01 degree per LSB (36000 = one turn).
    #[arg(long, value_parser = parse::angle_control, allow_hyphen_values = true)]
    angle_control: Option<AngleControl>,
    /// Target angle in degrees (rounded to 0.01°).
    #[arg(long, value_parser = parse::angle_deg, allow_hyphen_values = true)]
    deg: Option<AngleControl>,
}

impl MultiTurnAngle {
    fn value(&self) -> AngleControl {
        self.angle_control.or(self.deg).unwrap_or_default()
    }
}

/// A single-turn target angle, raw or in degrees.
#[derive(Args, Debug)]
#[command(group(ArgGroup::new("angle").required(true).args(["angle_control", "deg"])))]
struct SingleTurn {
    /// Target angle (angleControl), 0..=35999, 0.01 degree per LSB.
    #[arg(long, value_parser = parse::single_turn_angle, allow_hyphen_values = true)]
    angle_control: Option<SingleTurnAngle>,
    /// Target angle in degrees, 0..<360 (rounded to 0.01°).
    #[arg(long, value_parser = parse::single_turn_deg, allow_hyphen_values = true)]
    deg: Option<SingleTurnAngle>,
}

impl SingleTurn {
    fn value(&self) -> SingleTurnAngle {
        self.angle_control.or(self.deg).unwrap_or_default()
    }
}

/// `--spin-direction`.
#[derive(Copy, Clone, Debug, ValueEnum)]
enum Spin {
    /// Clockwise (0x00).
    Cw,
    /// Counterclockwise (0x01).
    Ccw,
}

impl From<Spin> for SpinDirection {
    fn from(s: Spin) -> Self {
        match s {
            Spin::Cw => SpinDirection::Clockwise,
            Spin::Ccw => SpinDirection::CounterClockwise,
        }
    }
}

#[derive(Args, Debug)]
struct Position1Args {
    #[command(flatten)]
    target: Target,
    #[command(flatten)]
    angle: MultiTurnAngle,
}

#[derive(Args, Debug)]
struct Position2Args {
    #[command(flatten)]
    target: Target,
    /// Speed limit (maxSpeed), 0..=65535 dps.
    #[arg(long, value_parser = parse::max_speed)]
    max_speed: MaxSpeed,
    #[command(flatten)]
    angle: MultiTurnAngle,
}

#[derive(Args, Debug)]
struct Position3Args {
    #[command(flatten)]
    target: Target,
    /// Spin direction (spinDirection).
    #[arg(long, value_enum)]
    spin_direction: Spin,
    #[command(flatten)]
    angle: SingleTurn,
}

#[derive(Args, Debug)]
struct Position4Args {
    #[command(flatten)]
    target: Target,
    /// Spin direction (spinDirection).
    #[arg(long, value_enum)]
    spin_direction: Spin,
    /// Speed limit (maxSpeed), 0..=65535 dps.
    #[arg(long, value_parser = parse::max_speed)]
    max_speed: MaxSpeed,
    #[command(flatten)]
    angle: SingleTurn,
}

#[derive(Args, Debug)]
#[command(group(ArgGroup::new("current").required(true).args(["iq_control", "amps"])))]
struct MultiTorqueArgs {
    /// Torque currents of motors 1..=4 (iqControl), four comma-separated raw values, in the
    /// scale of `torque --iq-control` (v1.61: -2000..=2000 at 32/2000 A per LSB; LK MF / MG:
    /// -2048..=2048 at 16.5/2048 / 33/2048 A per LSB).
    #[arg(long, value_parser = parse::raw_int4, allow_hyphen_values = true)]
    iq_control: Option<[i64; 4]>,
    /// Torque currents of motors 1..=4 in amperes, four comma-separated values (v1.61: ±32 A;
    /// LK MF: ±16.5 A; LK MG: ±33 A).
    #[arg(long, value_parser = parse::number4, allow_hyphen_values = true)]
    amps: Option<[f64; 4]>,
}

#[derive(Subcommand, Debug)]
enum EncodeCommand {
    /// 0x30: read the PID parameters.
    #[command(name = "read-pid")]
    ReadPid(Target),
    /// 0x31: write the PID parameters to RAM.
    #[command(name = "write-pid-ram")]
    WritePidRam(PidArgs),
    /// 0x32: write the PID parameters to ROM (wears the flash).
    #[command(name = "write-pid-rom")]
    WritePidRom(PidArgs),
    /// 0x33: read the acceleration.
    #[command(name = "read-accel")]
    ReadAccel(Target),
    /// 0x34: write the acceleration to RAM.
    #[command(name = "write-accel-ram")]
    WriteAccelRam(AccelArgs),
    /// 0x90: read the encoder.
    #[command(name = "read-encoder")]
    ReadEncoder(Target),
    /// 0x91: write the encoder offset.
    #[command(name = "write-encoder-offset")]
    WriteEncoderOffset(EncoderOffsetArgs),
    /// 0x19: write the current position to ROM as zero (wears the flash; needs a power cycle).
    #[command(name = "write-zero-rom")]
    WriteZeroRom(Target),
    /// 0x92: read the multi-turn angle.
    #[command(name = "read-multi-turn-angle")]
    ReadMultiTurnAngle(Target),
    /// 0x94: read the single-turn angle.
    #[command(name = "read-single-turn-angle")]
    ReadSingleTurnAngle(Target),
    /// 0x9A: read status 1 (temperature, voltage, error flags).
    #[command(name = "read-status-1")]
    ReadStatus1(Target),
    /// 0x9B: clear the error flags.
    #[command(name = "clear-error")]
    ClearError(Target),
    /// 0x9C: read status 2 (temperature, torque current, speed, encoder).
    #[command(name = "read-status-2")]
    ReadStatus2(Target),
    /// 0x9D: read status 3 (phase currents).
    #[command(name = "read-status-3")]
    ReadStatus3(Target),
    /// 0x80: motor off.
    #[command(name = "motor-off")]
    MotorOff(Target),
    /// 0x81: motor stop.
    #[command(name = "motor-stop")]
    MotorStop(Target),
    /// 0x88: motor run.
    #[command(name = "motor-run")]
    MotorRun(Target),
    /// 0xA1: torque closed loop (--iq-control or --amps).
    #[command(name = "torque")]
    Torque(TorqueArgs),
    /// 0xA2: speed closed loop (--speed-control or --dps).
    #[command(name = "speed")]
    Speed(SpeedArgs),
    /// 0xA3: position closed loop 1, multi-turn (--angle-control or --deg).
    #[command(name = "position-1")]
    Position1(Position1Args),
    /// 0xA4: position closed loop 2, multi-turn with speed limit.
    #[command(name = "position-2")]
    Position2(Position2Args),
    /// 0xA5: position closed loop 3, single-turn with direction.
    #[command(name = "position-3")]
    Position3(Position3Args),
    /// 0xA6: position closed loop 4, single-turn with direction and speed limit.
    #[command(name = "position-4")]
    Position4(Position4Args),
    /// 0x280: torque for motors 1..=4 in one frame (no --id).
    #[command(name = "multi-torque")]
    MultiTorque(MultiTorqueArgs),
}

/// The torque current of `--iq-control` (raw) or `--amps` in `dialect`'s `iqControl` scale.
fn current(dialect: Dialect, raw: Option<i64>, amps: Option<f64>) -> Result<ScaledCurrent, String> {
    rmd_frames::encode::torque_current(dialect, raw, amps)
}

/// Builds the frame the command line asks for, in `dialect`.
fn frame(command: EncodeCommand, dialect: Dialect) -> Result<CanFrame, String> {
    use EncodeCommand as C;
    let single = |t: Target, r: Request| Ok(r.encode(t.id));
    match command {
        C::ReadPid(t) => single(t, Request::ReadPid),
        C::WritePidRam(a) => single(a.target, Request::WritePidRam(a.params())),
        C::WritePidRom(a) => single(a.target, Request::WritePidRom(a.params())),
        C::ReadAccel(t) => single(t, Request::ReadAccel),
        C::WriteAccelRam(a) => single(a.target, Request::WriteAccelRam { accel: a.accel }),
        C::ReadEncoder(t) => single(t, Request::ReadEncoder),
        C::WriteEncoderOffset(a) => {
            let encoder_offset =
                rmd_frames::encode::encoder_offset(a.encoder_offset, a.encoder_bits)?;
            single(a.target, Request::WriteEncoderOffset { encoder_offset })
        }
        C::WriteZeroRom(t) => single(t, Request::WriteZeroRom),
        C::ReadMultiTurnAngle(t) => single(t, Request::ReadMultiTurnAngle),
        C::ReadSingleTurnAngle(t) => single(t, Request::ReadSingleTurnAngle),
        C::ReadStatus1(t) => single(t, Request::ReadStatus1),
        C::ClearError(t) => single(t, Request::ClearError),
        C::ReadStatus2(t) => single(t, Request::ReadStatus2),
        C::ReadStatus3(t) => single(t, Request::ReadStatus3),
        C::MotorOff(t) => single(t, Request::MotorOff),
        C::MotorStop(t) => single(t, Request::MotorStop),
        C::MotorRun(t) => single(t, Request::MotorRun),
        C::Torque(a) => {
            let request = DialectRequest::Torque {
                motor: a.target.id,
                iq_control: current(dialect, a.iq_control, a.amps)?,
            };
            encode_request_with(dialect, &request).map_err(|e| e.to_string())
        }
        C::Speed(a) => {
            let speed_control = a
                .speed_control
                .or(a.dps)
                .ok_or("missing --speed-control or --dps")?;
            single(a.target, Request::Speed { speed_control })
        }
        C::Position1(a) => single(
            a.target,
            Request::Position1 {
                angle_control: a.angle.value(),
            },
        ),
        C::Position2(a) => single(
            a.target,
            Request::Position2 {
                max_speed: a.max_speed,
                angle_control: a.angle.value(),
            },
        ),
        C::Position3(a) => single(
            a.target,
            Request::Position3 {
                spin_direction: a.spin_direction.into(),
                angle_control: a.angle.value(),
            },
        ),
        C::Position4(a) => single(
            a.target,
            Request::Position4 {
                spin_direction: a.spin_direction.into(),
                max_speed: a.max_speed,
                angle_control: a.angle.value(),
            },
        ),
        C::MultiTorque(a) => {
            let mut iq = [ScaledCurrent::saturating(0, dialect.iq_control_scale()); 4];
            for (k, slot) in iq.iter_mut().enumerate() {
                *slot = current(dialect, a.iq_control.map(|v| v[k]), a.amps.map(|v| v[k]))?;
            }
            let request = DialectRequest::MultiTorque(ScaledMultiTorque::new(iq));
            encode_request_with(dialect, &request).map_err(|e| e.to_string())
        }
    }
}

/// Runs `rmd encode`: prints the frame, or one error line.
pub(crate) fn run(args: EncodeArgs) -> ExitCode {
    let dialect = match args.protocol.dialect() {
        Ok(dialect) => dialect,
        Err(message) => return report::usage_error(message),
    };
    match frame(args.command, dialect) {
        Ok(frame) => report::exit(outln!("{frame}").map_err(Into::into)),
        Err(message) => report::usage_error(message),
    }
}
