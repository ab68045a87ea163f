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
//!
//! `--protocol myactuator-v3` encodes for MyActuator's V3 driver (protocol manuals V4.3 / V4.4):
//! its commands (the ones v1.61 shares, and `read-firmware-date`, `read-model`, `set-watchdog`,
//! `function-control`, `reset`, `brake-release`, `brake-lock`), its 0.01 A current scale, `speed
//! --max-torque`, `--broadcast` (0x280: one command for every motor) and `motion` (the
//! motion-mode frame on 0x400 + id, packed with the ranges of `--firmware-date`). A command or a
//! field the protocol does not have is refused with the reason.

use std::process::ExitCode;

use clap::{ArgGroup, Args, Subcommand, ValueEnum};
use rmd_protocol::{
    Accel, AngleControl, CanFrame, Dialect, EncoderWidth, FunctionControl, MaxSpeed,
    MaxTorquePercent, MitCommand, ModelIndex, ModelPart, MotorId, MultiTorque, PidParams,
    ProtocolError, Request, ScaledCurrent, SingleTurnAngle, SpeedControl, SpinDirection,
    V3Function, WatchdogTimeout,
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

/// The motor a single-motor command goes to, or (MyActuator V3) every motor.
#[derive(Args, Copy, Clone, Debug)]
#[command(group(ArgGroup::new("target").required(true).args(["id", "broadcast"])))]
struct Target {
    /// Motor id, 1..=32 (CAN ID 0x140 + id).
    #[arg(long, value_parser = parse::motor_id)]
    id: Option<MotorId>,
    /// MyActuator V3: send the command to every motor of the bus at once, on 0x280 (each
    /// answers on its own 0x240 + id; motors with the CAN ID filter on do not hear it).
    #[arg(long)]
    broadcast: bool,
}

/// A motor id only (the motion-mode frame has no broadcast form).
#[derive(Args, Copy, Clone, Debug)]
struct MotorTarget {
    /// Motor id, 1..=32 (CAN ID 0x400 + id).
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
    /// lk-v2.3x; i16 at 0.01 A per LSB with --protocol myactuator-v3.
    #[arg(long, value_parser = parse::raw_int, allow_hyphen_values = true)]
    iq_control: Option<i64>,
    /// Torque current in amperes, rounded to the protocol's step: -32..=32 A in steps of
    /// 0.016 A (32/2000) in v1.61; ±16.5 A in steps of 16.5/2048 A (LK MF) or ±33 A in steps of
    /// 33/2048 A (LK MG) with --protocol lk-v2.3x; steps of 0.01 A with --protocol
    /// myactuator-v3.
    #[arg(long, value_parser = parse::number, allow_hyphen_values = true)]
    amps: Option<f64>,
}

#[derive(Args, Debug)]
#[command(group(ArgGroup::new("speed").required(true).args(["speed_control", "dps"])))]
struct SpeedArgs {
    #[command(flatten)]
    target: Target,
    /// Speed (speedControl), i32, 0.01 dps per LSB (MyActuator V3: the output shaft's).
    #[arg(long, value_parser = parse::speed_control, allow_hyphen_values = true)]
    speed_control: Option<SpeedControl>,
    /// Speed in degrees per second (rounded to 0.01 dps).
    #[arg(long, value_parser = parse::speed_dps, allow_hyphen_values = true)]
    dps: Option<SpeedControl>,
    /// MyActuator V3: torque limit (maxTorque, byte 1) in percent of the rated current,
    /// 1..=255; 0 or absent, none.
    #[arg(long, value_name = "PERCENT")]
    max_torque: Option<u8>,
}

/// `read-model`.
#[derive(Args, Debug)]
struct ReadModelArgs {
    #[command(flatten)]
    target: Target,
    /// V4.4 firmware: which five characters, 1..=3 (`B5 01 INDEX`); absent: V4.3's form
    /// (`B5 00`), the whole model.
    #[arg(long)]
    index: Option<u8>,
}

/// `set-watchdog`.
#[derive(Args, Debug)]
struct WatchdogArgs {
    #[command(flatten)]
    target: Target,
    /// Communication-interruption protection time, ms (CanRecvTime_MS); 0 disables it. The
    /// motor stores it in ROM.
    #[arg(long, value_name = "MS")]
    timeout_ms: u32,
}

/// `--function` of `function-control`.
#[derive(Copy, Clone, Debug, ValueEnum)]
enum Function {
    /// 0x01: clear the multi-turn value (after a restart).
    ClearMultiTurn,
    /// 0x02: CAN ID filter (1 on; 0 off, needed for 0x280).
    CanIdFilter,
    /// 0x03: send 0x9A every 100 ms while in error (1 on).
    ErrorStatusTransmission,
    /// 0x04: save the multi-turn value at power-off (1 on).
    SaveMultiTurnAtPowerOff,
    /// 0x05: set the CAN ID (after a reboot).
    SetCanId,
    /// 0x06: maximum positive angle of position mode.
    MaxPositiveAngle,
    /// 0x07: maximum negative angle of position mode.
    MaxNegativeAngle,
    /// 0x08 (V4.4): over/under-voltage and over-speed errors recover automatically (1 on).
    ErrorAutoRecovery,
}

impl From<Function> for V3Function {
    fn from(f: Function) -> Self {
        match f {
            Function::ClearMultiTurn => V3Function::ClearMultiTurn,
            Function::CanIdFilter => V3Function::CanIdFilter,
            Function::ErrorStatusTransmission => V3Function::ErrorStatusTransmission,
            Function::SaveMultiTurnAtPowerOff => V3Function::SaveMultiTurnAtPowerOff,
            Function::SetCanId => V3Function::SetCanId,
            Function::MaxPositiveAngle => V3Function::MaxPositiveAngle,
            Function::MaxNegativeAngle => V3Function::MaxNegativeAngle,
            Function::ErrorAutoRecovery => V3Function::ErrorAutoRecovery,
        }
    }
}

/// `function-control`.
#[derive(Args, Debug)]
struct FunctionArgs {
    #[command(flatten)]
    target: Target,
    /// The function (byte 1).
    #[arg(long, value_enum)]
    function: Function,
    /// Its value (bytes 4..=7, u32).
    #[arg(long, default_value = "0")]
    value: u32,
}

/// `motion`: the five fields of the motion-mode command, at the output shaft.
#[derive(Args, Debug)]
struct MotionArgs {
    #[command(flatten)]
    target: MotorTarget,
    /// Desired position p_des, rad (V4.3: ±12.5; V4.4: ±12.566).
    #[arg(long, value_parser = parse::finite, allow_hyphen_values = true)]
    p_des: f64,
    /// Desired velocity v_des, rad/s (±45).
    #[arg(long, value_parser = parse::finite, allow_hyphen_values = true, default_value = "0")]
    v_des: f64,
    /// Position gain kp, N·m/rad (0..=500).
    #[arg(long, value_parser = parse::finite, default_value = "0")]
    kp: f64,
    /// Velocity gain kd, N·m·s/rad (V4.3: 0..=5; V4.4: 0..=50).
    #[arg(long, value_parser = parse::finite, default_value = "0")]
    kd: f64,
    /// Feed-forward torque t_ff, N·m (V4.3: ±24; V4.4: ± --motor-max-torque).
    #[arg(long, value_parser = parse::finite, allow_hyphen_values = true, default_value = "0")]
    t_ff: f64,
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
    /// 0x280: torque for motors 1..=4 in one frame (no --id; v1.61 and LK-TECH).
    #[command(name = "multi-torque")]
    MultiTorque(MultiTorqueArgs),
    /// 0xB2 (MyActuator V3): read the firmware version date.
    #[command(name = "read-firmware-date")]
    ReadFirmwareDate(Target),
    /// 0xB5 (MyActuator V3): read the motor model.
    #[command(name = "read-model")]
    ReadModel(ReadModelArgs),
    /// 0xB3 (MyActuator V3): set the communication-interruption protection time (ROM).
    #[command(name = "set-watchdog")]
    SetWatchdog(WatchdogArgs),
    /// 0x20 (MyActuator V3): function control (most functions write ROM).
    #[command(name = "function-control")]
    FunctionControl(FunctionArgs),
    /// 0x76 (MyActuator V3): system reset (no reply; the motor reboots).
    #[command(name = "reset")]
    Reset(Target),
    /// 0x77 (MyActuator V3): release the brake.
    #[command(name = "brake-release")]
    BrakeRelease(Target),
    /// 0x78 (MyActuator V3): lock the brake.
    #[command(name = "brake-lock")]
    BrakeLock(Target),
    /// 0x400 + id (MyActuator V3): motion mode (p_des, v_des, kp, kd, t_ff at the output).
    #[command(name = "motion")]
    Motion(MotionArgs),
}

/// The torque current of `--iq-control` (raw) or `--amps` in `dialect`'s `iqControl` scale.
fn current(dialect: Dialect, raw: Option<i64>, amps: Option<f64>) -> Result<ScaledCurrent, String> {
    rmd_frames::encode::torque_current(dialect, raw, amps)
}

/// Builds the frame the command line asks for, in `dialect`.
fn frame(command: EncodeCommand, dialect: Dialect) -> Result<CanFrame, String> {
    use EncodeCommand as C;
    let single = |t: Target, r: Request| {
        match t.id {
            Some(id) => dialect.encode(id, &r),
            None => dialect.encode_broadcast(&r),
        }
        .map_err(|e| e.to_string())
    };
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
        C::Torque(a) => single(
            a.target,
            Request::Torque {
                iq_control: current(dialect, a.iq_control, a.amps)?,
            },
        ),
        C::Speed(a) => {
            let speed_control = a
                .speed_control
                .or(a.dps)
                .ok_or("missing --speed-control or --dps")?;
            let max_torque = MaxTorquePercent::new(a.max_torque.unwrap_or(0));
            single(
                a.target,
                Request::Speed {
                    speed_control,
                    max_torque,
                },
            )
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
            dialect
                .encode_multi_torque(&MultiTorque::new(iq))
                .map_err(|e| e.to_string())
        }
        C::ReadFirmwareDate(t) => single(t, Request::ReadFirmwareDate),
        C::ReadModel(a) => {
            let part = match a.index {
                Some(index) => {
                    ModelPart::Chars(ModelIndex::new(index).map_err(|e| format!("--index: {e}"))?)
                }
                None => ModelPart::Whole,
            };
            single(a.target, Request::ReadModel { part })
        }
        C::SetWatchdog(a) => single(
            a.target,
            Request::SetWatchdog {
                timeout: WatchdogTimeout::from_millis(a.timeout_ms),
            },
        ),
        C::FunctionControl(a) => single(
            a.target,
            Request::FunctionControl(FunctionControl {
                function: a.function.into(),
                value: a.value,
            }),
        ),
        C::Reset(t) => single(t, Request::Reset),
        C::BrakeRelease(t) => single(t, Request::BrakeRelease),
        C::BrakeLock(t) => single(t, Request::BrakeLock),
        C::Motion(a) => {
            let ranges = dialect.mit_ranges().map_err(|e| match e {
                ProtocolError::MissingMaxTorque => format!("{e} with --motor-max-torque NM"),
                other => other.to_string(),
            })?;
            let command = MitCommand::from_si(ranges, a.p_des, a.v_des, a.kp, a.kd, a.t_ff)
                .map_err(|e| format!("{e} (motion-mode ranges of {dialect}: {ranges})"))?;
            dialect
                .encode_mit(a.target.id, &command)
                .map_err(|e| e.to_string())
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
