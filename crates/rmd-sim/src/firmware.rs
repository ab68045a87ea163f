//! The firmware of one motor: command handling, RAM and ROM, modes, protection flags, and the
//! choice of what the power stage does each substep.
//!
//! How the simulated firmware reads the spec (v1.61 and its reading notes):
//!
//! - **RAM / ROM.** PID gains: 0x31 writes RAM, 0x32 writes ROM and RAM; 0x30 reads RAM. The
//!   acceleration: 0x34 writes RAM, 0x33 reads it; ROM holds the configured value. Encoder
//!   offset: 0x91 writes the offset in use (RAM: the spec does not say it is persistent, unlike
//!   0x19 and 0x32); 0x19 writes the current raw position to ROM as the zero offset, which only
//!   takes effect after a power cycle, and replies with the offset written. A power cycle
//!   reloads RAM from ROM, turns the motor off and restarts the multi-turn count.
//! - **Angles.** `encoder = (encoderRaw - encoderOffset) mod 2^bits`. The multi-turn angle
//!   (0x92) counts from the encoder zero and starts within 0..360° at power-up; the single-turn
//!   angle (0x94) is the encoder position in 0.01°. Positive is "clockwise".
//! - **Modes.** 0xA1 / 0x280 torque (`iqControl`, not limited by the max torque current), 0xA2
//!   speed (acceleration-limited ramp, max torque current), 0xA3 / 0xA4 multi-turn position (max
//!   angle, max speed from the settings / from the frame, acceleration, max torque current), 0xA5
//!   / 0xA6 single-turn position (the target single-turn angle reached turning in the given
//!   direction, 0 clockwise = positive; max speed from the settings / from the frame). A control
//!   command also resumes a stopped motor.
//! - **Off / stop / run.** 0x80 turns the output off and forgets the mode; 0x81 turns the output
//!   off but keeps the mode; 0x88 resumes the kept mode (nothing after 0x80). 0x81 lets the
//!   rotor coast (no braking).
//! - **Protection.** The low-voltage flag (bit 0) is raised when the supply falls below the
//!   threshold, the over-temperature flag (bit 3) when the winding reaches its threshold.
//!   Flags latch. Raising one turns the motor off (as 0x80); while any flag is set, control
//!   commands are answered but not obeyed. 0x9B clears only the flags whose cause is gone: the
//!   supply back above threshold + hysteresis, the winding back below threshold - hysteresis.
//! - **Replies** carry the state sampled at the last control-loop step before the request.
//! - **Other firmware.** A motor whose [`FirmwareParams::family`] is LK-TECH V2.3x runs this
//!   firmware with LK's layouts, scales and off state (`lk`); a MyActuator V3 motor speaks V3
//!   (`v3`: its commands, the output shaft's units, the motion mode, the watchdog, the brake,
//!   reset; see `docs/simulator.md`, "Other firmware and firmware traps", for the exact lists and
//!   their sources). Every reply is built in the motor's [`Dialect`] and encoded by the codec.
//!   [`FirmwareParams::traps`] adds the firmware-state traps reported from real motors, each off
//!   by default.

use core::f64::consts::PI;

use rmd_protocol::{
    Accel, CircleAngle, Dialect, ErrorState, MotorAngle, PhaseCurrent, PidParams, Reply, Request,
    ScaledCurrent, Speed, SpinDirection, Status1, Status2, Status3, StatusPosition, Temperature,
    V161Status1, Voltage,
};

use crate::config::{ClearErrorReply, FirmwareParams};
use crate::control::{
    FirmwareGains, LoopState, POSITION_MODE_SETPOINT_WEIGHT, SPEED_MODE_SETPOINT_WEIGHT,
    profile_step, ramp, speed_loop,
};
use crate::encoder::Encoder;
use crate::family::{FirmwareFamily, FirmwareTraps};
use crate::physics::{Drive, Plant, SUBSTEP_S};

mod lk;
mod v3;

pub use v3::SIM_V3_MODEL;
pub(crate) use v3::V3State;

const DEG: f64 = PI / 180.0;

/// The control mode the firmware is in.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum ControlMode {
    /// Output off, no command (after power-up, 0x80, or a protection trip).
    Off,
    /// Torque (current) loop, reference in A.
    Torque {
        /// Torque current reference, A.
        current_a: f64,
    },
    /// Speed loop, target in motor-side dps.
    Speed {
        /// Target speed, dps.
        target_dps: f64,
    },
    /// Position loop, target multi-turn angle in motor-side degrees.
    Position {
        /// Target angle, degrees.
        target_deg: f64,
        /// Speed limit, dps.
        max_speed_dps: f64,
    },
    /// MyActuator V3's motion mode: `IqRef = [kp (p_des - p) + kd (v_des - v) + t_ff] / KT_OUT`,
    /// every quantity at the output shaft (V4.4 §4.1).
    Motion {
        /// `p_des`, output rad.
        position_rad: f64,
        /// `v_des`, output rad/s.
        velocity_rad_s: f64,
        /// `kp`, N·m per rad.
        kp: f64,
        /// `kd`, N·m per rad/s.
        kd: f64,
        /// `t_ff`, output N·m.
        torque_nm: f64,
    },
}

#[derive(Copy, Clone, Debug, PartialEq)]
struct Memory {
    pid: PidParams,
    accel: Accel,
    /// Encoder offset at full resolution.
    offset: i64,
}

/// The firmware state of one motor.
#[derive(Clone, Debug)]
pub(crate) struct Firmware {
    params: FirmwareParams,
    encoder: Encoder,
    rom: Memory,
    ram: Memory,
    /// Whole turns subtracted so that the multi-turn angle starts within one turn at power-up.
    power_on_turns: i64,
    mode: ControlMode,
    stopped: bool,
    loops: LoopState,
    errors: ErrorState,
    nominal_current_time_constant_s: f64,
    /// The rotor's inertia over the torque constant, A per rad/s²: the firmware knows its own
    /// motor (not the load) and feeds accelerations forward with it in position mode.
    rotor_inertia_per_kt: f64,
    /// LK-TECH: switched off by 0x80 until 0x88 (control commands answered, not obeyed).
    lk_off: bool,
    /// Control commands of the request being handled are answered but not obeyed (the
    /// "motion ignored after 0x88" trap; set by the motor for one request).
    ignore_motion: bool,
    /// The torque-current limit of the current command (V3 0xA2's `maxTorque`), A.
    command_limit_a: Option<f64>,
    /// MyActuator V3's own state (brake, watchdog, function settings).
    pub(crate) v3: V3State,
}

impl Firmware {
    /// Firmware just powered up with `params` on `plant`.
    pub(crate) fn new(params: FirmwareParams, plant: &Plant) -> Self {
        let encoder = Encoder::new(
            params.encoder_width,
            plant.params().encoder_mount_offset_turns,
        );
        let rom = Memory {
            pid: params.pid,
            accel: params.accel,
            offset: encoder.count_of(params.encoder_offset),
        };
        let mut fw = Self {
            params,
            encoder,
            rom,
            ram: rom,
            power_on_turns: 0,
            mode: ControlMode::Off,
            stopped: false,
            loops: LoopState::default(),
            errors: ErrorState::NONE,
            nominal_current_time_constant_s: plant.params().current_time_constant_s,
            rotor_inertia_per_kt: plant.params().rotor_inertia_kg_m2
                / plant.params().torque_constant_nm_per_a,
            lk_off: false,
            ignore_motion: false,
            command_limit_a: None,
            v3: V3State::new(&params.v3),
        };
        fw.power_up(plant);
        fw
    }

    /// A power cycle: RAM from ROM, motor off, flags re-evaluated, multi-turn count restarted.
    pub(crate) fn power_up(&mut self, plant: &Plant) {
        self.ram = Memory {
            accel: self.params.accel,
            ..self.rom
        };
        self.mode = ControlMode::Off;
        self.stopped = false;
        self.loops = LoopState::default();
        self.errors = ErrorState::NONE;
        self.lk_off = false;
        self.command_limit_a = None;
        self.v3.power_up(&self.params.v3);
        self.restart_turn_count(plant);
        self.supervise(plant);
    }

    /// Restarts the multi-turn count: the multi-turn angle is back within one turn of the
    /// encoder zero (at power-up; after 0x80 with the `motor_off_clears_turns` trap).
    fn restart_turn_count(&mut self, plant: &Plant) {
        let abs = self.encoder.absolute_count(plant.state().motor_angle_rad);
        self.power_on_turns = (abs - self.ram.offset).div_euclid(self.encoder.counts());
    }

    /// The firmware family.
    pub(crate) fn family(&self) -> FirmwareFamily {
        self.params.family
    }

    /// The dialect it speaks.
    pub(crate) fn dialect(&self) -> Dialect {
        match self.params.family {
            FirmwareFamily::V161 => Dialect::V161,
            FirmwareFamily::LkV23x(series) => Dialect::LkV23x(series),
            FirmwareFamily::MyActuatorV3 => Dialect::MyActuatorV3(self.params.v3.firmware()),
        }
    }

    /// The traps set.
    pub(crate) fn traps(&self) -> FirmwareTraps {
        self.params.traps
    }

    /// Makes the control commands of the next requests answered but not obeyed (`true`) or
    /// obeyed again (`false`).
    pub(crate) fn set_ignore_motion(&mut self, ignore: bool) {
        self.ignore_motion = ignore;
    }

    pub(crate) fn mode(&self) -> ControlMode {
        self.mode
    }

    pub(crate) fn stopped(&self) -> bool {
        self.stopped
    }

    pub(crate) fn errors(&self) -> ErrorState {
        self.errors
    }

    pub(crate) fn pid_ram(&self) -> PidParams {
        self.ram.pid
    }

    pub(crate) fn pid_rom(&self) -> PidParams {
        self.rom.pid
    }

    fn gains(&self) -> FirmwareGains {
        FirmwareGains::from_pid(&self.ram.pid, self.nominal_current_time_constant_s)
    }

    /// Whether the power stage is driven.
    pub(crate) fn output_enabled(&self) -> bool {
        !self.stopped
            && self.errors.is_clear()
            && self.mode != ControlMode::Off
            && !self.v3.holds_output(&self.params.v3)
    }

    /// Whether the firmware applies, or is commanded to apply, torque: its output is enabled
    /// in a mode other than zero torque.
    pub(crate) fn energising(&self) -> bool {
        self.output_enabled() && self.mode != ControlMode::Torque { current_a: 0.0 }
    }

    // ---- Measurements, as the firmware sees them -------------------------------------------

    fn absolute_count(&self, plant: &Plant) -> i64 {
        self.encoder.absolute_count(plant.state().motor_angle_rad)
    }

    /// Multi-turn position in full-resolution counts from the encoder zero.
    fn position_counts(&self, plant: &Plant) -> i64 {
        self.absolute_count(plant) - self.ram.offset - self.power_on_turns * self.encoder.counts()
    }

    /// Multi-turn position, rad.
    fn position_rad(&self, plant: &Plant) -> f64 {
        self.position_counts(plant) as f64 * core::f64::consts::TAU / self.encoder.counts() as f64
    }

    /// Multi-turn angle in 0.01° (floor).
    fn motor_angle_centideg(&self, plant: &Plant) -> i64 {
        (i128::from(self.position_counts(plant)) * 36_000)
            .div_euclid(i128::from(self.encoder.counts())) as i64
    }

    /// `encoder` (offset applied), full resolution.
    fn encoder_counts(&self, plant: &Plant) -> i64 {
        (self.absolute_count(plant) - self.ram.offset).rem_euclid(self.encoder.counts())
    }

    /// Single-turn angle in 0.01°, 0..=35999.
    fn circle_angle_centideg(&self, plant: &Plant) -> i64 {
        self.encoder_counts(plant) * 36_000 / self.encoder.counts()
    }

    /// Status 1 in the family's layout.
    fn status1(&self, plant: &Plant) -> Status1 {
        match self.params.family {
            FirmwareFamily::V161 => Status1::V161(V161Status1 {
                temperature: temperature(plant),
                voltage: Voltage::from_volts_saturating(plant.state().bus_voltage_v),
                error_state: self.errors,
            }),
            FirmwareFamily::LkV23x(_) => Status1::Lk(self.lk_status1(plant)),
            FirmwareFamily::MyActuatorV3 => Status1::V3(self.v3_status1(plant)),
        }
    }

    /// Status 2 in the family's scale and units: the motor's speed and encoder (v1.61,
    /// LK-TECH), the output shaft's speed and angle (V3).
    fn status2(&self, plant: &Plant) -> Status2 {
        let s = plant.state();
        let iq = ScaledCurrent::from_amps_saturating(s.current_a, self.dialect().iq_scale());
        match self.params.family {
            FirmwareFamily::MyActuatorV3 => self.v3_status2(plant, iq),
            FirmwareFamily::V161 | FirmwareFamily::LkV23x(_) => Status2 {
                temperature: temperature(plant),
                iq,
                speed: Speed::from_dps_saturating(s.motor_speed_rad_s / DEG),
                position: StatusPosition::Encoder(
                    self.encoder.wire_value(self.encoder_counts(plant)),
                ),
            },
        }
    }

    fn status3(&self, plant: &Plant) -> Status3 {
        // Inverse Park with id = 0, electrical zero at rotor angle zero:
        // i_x = -iq sin(theta_e - k 2pi/3).
        let iq = plant.state().current_a;
        let theta = plant.electrical_angle_rad();
        let phase = |shift: f64| PhaseCurrent::from_amps_saturating(-iq * (theta - shift).sin());
        Status3 {
            i_a: phase(0.0),
            i_b: phase(2.0 * PI / 3.0),
            i_c: phase(-2.0 * PI / 3.0),
        }
    }

    // ---- Commands --------------------------------------------------------------------------

    /// Handles one request (decoded in this motor's dialect) at the plant's current state.
    /// `None`: the request is not valid for this motor (an encoder offset beyond its encoder
    /// width) and is ignored, unanswered; or it is not answered (V3's 0x76).
    pub(crate) fn handle(&mut self, request: &Request, plant: &Plant) -> Option<Reply> {
        if let FirmwareFamily::MyActuatorV3 = self.params.family
            && let Some(reply) = self.handle_v3(request, plant)
        {
            return reply;
        }
        if let FirmwareFamily::LkV23x(_) = self.params.family
            && *request == Request::MotorRun
        {
            self.lk_off = false;
        }
        let reply = self.handle_common(request, plant);
        if let FirmwareFamily::LkV23x(_) = self.params.family
            && *request == Request::MotorOff
        {
            self.lk_off = true;
        }
        reply
    }

    /// The commands every family shares, with the family's layouts.
    fn handle_common(&mut self, request: &Request, plant: &Plant) -> Option<Reply> {
        Some(match *request {
            Request::ReadPid => Reply::ReadPid(self.ram.pid),
            Request::WritePidRam(pid) => {
                self.ram.pid = pid;
                Reply::WritePidRam(pid)
            }
            Request::WritePidRom(pid) => {
                self.rom.pid = pid;
                self.ram.pid = pid;
                Reply::WritePidRom(pid)
            }
            Request::ReadAccel => Reply::ReadAccel {
                accel: self.ram.accel,
            },
            Request::WriteAccelRam { accel } => {
                self.ram.accel = accel;
                Reply::WriteAccelRam { accel }
            }
            Request::ReadEncoder => {
                let raw = self.encoder.raw(self.absolute_count(plant));
                Reply::ReadEncoder {
                    encoder: self.encoder.wire_value(self.encoder_counts(plant)),
                    encoder_raw: self.encoder.wire_value(raw),
                    encoder_offset: self.encoder.wire_value(self.ram.offset),
                }
            }
            Request::WriteEncoderOffset { encoder_offset } => {
                encoder_offset.check(self.params.encoder_width).ok()?;
                self.ram.offset = self.encoder.count_of(encoder_offset);
                Reply::WriteEncoderOffset {
                    encoder_offset: self.encoder.wire_value(self.ram.offset),
                }
            }
            Request::WriteZeroRom => {
                self.rom.offset = self.encoder.raw(self.absolute_count(plant));
                Reply::WriteZeroRom {
                    encoder_offset: self.encoder.wire_value(self.rom.offset),
                }
            }
            Request::ReadMultiTurnAngle => Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::saturating(self.motor_angle_centideg(plant)),
            },
            Request::ReadSingleTurnAngle => match self.params.family {
                FirmwareFamily::LkV23x(_) => self.lk_single_turn_angle(plant),
                _ => Reply::ReadSingleTurnAngle {
                    circle_angle: CircleAngle::saturating(self.circle_angle_centideg(plant)),
                },
            },
            Request::ReadStatus1 => Reply::ReadStatus1(self.status1(plant)),
            Request::ClearError => {
                let causes = self.causes(plant, true);
                self.errors = ErrorState::from_raw(self.errors.raw() & causes.raw());
                let status = self.status1(plant);
                match self.params.clear_error_reply {
                    ClearErrorReply::Echo => Reply::ClearError(status),
                    ClearErrorReply::Status1Code => Reply::ReadStatus1(status),
                }
            }
            Request::ReadStatus2 => Reply::ReadStatus2(self.status2(plant)),
            Request::ReadStatus3 => Reply::ReadStatus3(self.status3(plant)),
            Request::MotorOff => {
                self.mode = ControlMode::Off;
                self.stopped = false;
                if self.params.traps.motor_off_clears_turns {
                    self.restart_turn_count(plant);
                }
                Reply::MotorOff
            }
            Request::MotorStop => {
                self.stopped = true;
                Reply::MotorStop
            }
            Request::MotorRun => {
                if self.stopped {
                    self.stopped = false;
                    self.loops = self.bumpless_start(self.mode, plant);
                }
                Reply::MotorRun
            }
            Request::Torque { iq_control } => self.torque(iq_control, plant),
            Request::Speed { speed_control, .. } => self.speed(speed_control.dps(), plant),
            Request::Position1 { angle_control } => {
                let reply = Reply::Position1(self.status2(plant));
                let target = self.clamp_to_max_angle(angle_control.degrees());
                self.command(self.position(target, self.params.max_speed_dps), plant);
                reply
            }
            Request::Position2 {
                max_speed,
                angle_control,
            } => self.position_2(angle_control.degrees(), max_speed.dps(), plant),
            Request::Position3 {
                spin_direction,
                angle_control,
            } => {
                let reply = Reply::Position3(self.status2(plant));
                let target = self.single_turn_target(spin_direction, angle_control.raw(), plant);
                self.command(self.position(target, self.params.max_speed_dps), plant);
                reply
            }
            Request::Position4 {
                spin_direction,
                max_speed,
                angle_control,
            } => {
                let reply = Reply::Position4(self.status2(plant));
                let target = self.single_turn_target(spin_direction, angle_control.raw(), plant);
                self.command(self.position(target, max_speed.dps()), plant);
                reply
            }
            // MyActuator V3's own commands are handled by `handle_v3`.
            Request::ReadFirmwareDate
            | Request::ReadModel { .. }
            | Request::SetWatchdog { .. }
            | Request::FunctionControl(_)
            | Request::Reset
            | Request::BrakeRelease
            | Request::BrakeLock => return None,
        })
    }

    /// A speed command (0xA2) to `target_dps` at the motor: the status-2 reply sampled before
    /// the command, then the command.
    pub(super) fn speed(&mut self, target_dps: f64, plant: &Plant) -> Reply {
        let reply = Reply::Speed(self.status2(plant));
        self.command(ControlMode::Speed { target_dps }, plant);
        reply
    }

    /// A position command with a speed limit (0xA4) to `target_deg` at the motor (within the
    /// maximum angle) at up to `max_speed_dps`: the status-2 reply sampled before the command,
    /// then the command.
    pub(super) fn position_2(
        &mut self,
        target_deg: f64,
        max_speed_dps: f64,
        plant: &Plant,
    ) -> Reply {
        let reply = Reply::Position2(self.status2(plant));
        let target = self.clamp_to_max_angle(target_deg);
        self.command(self.position(target, max_speed_dps), plant);
        reply
    }

    /// A torque command (0xA1, or this motor's slot of a 0x280 frame): the status-2 reply
    /// sampled before the command, then the command.
    pub(crate) fn torque(&mut self, iq_control: ScaledCurrent, plant: &Plant) -> Reply {
        let reply = Reply::Torque(self.status2(plant));
        self.command(
            ControlMode::Torque {
                current_a: iq_control.amps(),
            },
            plant,
        );
        reply
    }

    fn position(&self, target_deg: f64, max_speed_dps: f64) -> ControlMode {
        ControlMode::Position {
            target_deg,
            max_speed_dps,
        }
    }

    fn clamp_to_max_angle(&self, degrees: f64) -> f64 {
        match self.params.max_angle_deg {
            Some(max) => degrees.clamp(-max, max),
            None => degrees,
        }
    }

    /// The multi-turn target (degrees) that reaches single-turn angle `target` (0.01°) turning
    /// in `direction` from the current position.
    fn single_turn_target(&self, direction: SpinDirection, target: u16, plant: &Plant) -> f64 {
        let current = self.circle_angle_centideg(plant);
        let target = i64::from(target);
        let delta = match direction {
            SpinDirection::Clockwise => (target - current).rem_euclid(36_000),
            SpinDirection::CounterClockwise => -(current - target).rem_euclid(36_000),
        };
        (self.motor_angle_centideg(plant) + delta) as f64 / 100.0
    }

    /// Takes a new control command (ignored while a protection flag is set, while an LK motor
    /// is off, and for a request whose motion is to be ignored).
    fn command(&mut self, mode: ControlMode, plant: &Plant) {
        if !self.errors.is_clear() || self.lk_off || self.ignore_motion {
            return;
        }
        self.command_limit_a = None;
        let same_kind = core::mem::discriminant(&mode) == core::mem::discriminant(&self.mode);
        if !same_kind || self.stopped {
            self.loops = self.bumpless_start(mode, plant);
        }
        self.mode = mode;
        self.stopped = false;
    }

    fn bumpless_start(&self, mode: ControlMode, plant: &Plant) -> LoopState {
        let weight = match mode {
            ControlMode::Position { .. } => POSITION_MODE_SETPOINT_WEIGHT,
            _ => SPEED_MODE_SETPOINT_WEIGHT,
        };
        LoopState::start(
            self.position_rad(plant),
            plant.state().motor_speed_rad_s,
            plant.state().current_a,
            weight,
            &self.gains(),
        )
    }

    // ---- Protection ------------------------------------------------------------------------

    /// The flags whose cause is present now. Raising a flag takes the threshold itself;
    /// `persisting` asks whether the cause is still there for a clear, i.e. not yet back past
    /// the threshold by the hysteresis.
    fn causes(&self, plant: &Plant, persisting: bool) -> ErrorState {
        let s = plant.state();
        let p = &self.params;
        let (volts, celsius) = if persisting {
            (
                p.low_voltage_threshold_v + p.low_voltage_hysteresis_v,
                p.over_temperature_threshold_c - p.over_temperature_hysteresis_c,
            )
        } else {
            (p.low_voltage_threshold_v, p.over_temperature_threshold_c)
        };
        let mut causes = ErrorState::NONE;
        if s.bus_voltage_v < volts {
            causes = causes | ErrorState::LOW_VOLTAGE;
        }
        if s.winding_temperature_c >= celsius {
            causes = causes | ErrorState::OVER_TEMPERATURE;
        }
        causes
    }

    /// Raises the flags whose cause is present; a new flag turns the motor off. A V3 motor's
    /// flags of these two kinds clear themselves once their cause is gone (undervoltage and
    /// motor over-temperature are "level 2", auto-recovering errors: V4.4 §2.13, §7); v1.61 and
    /// LK-TECH flags latch until 0x9B.
    pub(crate) fn supervise(&mut self, plant: &Plant) {
        if let FirmwareFamily::MyActuatorV3 = self.params.family {
            let persisting = self.causes(plant, true);
            self.errors = ErrorState::from_raw(self.errors.raw() & persisting.raw());
        }
        let causes = self.causes(plant, false);
        let raised = causes.raw() & !self.errors.raw();
        if raised != 0 {
            self.errors = ErrorState::from_raw(self.errors.raw() | raised);
            self.mode = ControlMode::Off;
            self.stopped = false;
        }
    }

    // ---- Control loops ---------------------------------------------------------------------

    /// What the power stage does during the next substep.
    pub(crate) fn control(&mut self, plant: &Plant, max_current_a: f64) -> Drive {
        if !self.output_enabled() {
            return Drive::Disabled;
        }
        let gains = self.gains();
        let dt = SUBSTEP_S;
        let speed = plant.state().motor_speed_rad_s;
        let accel = self.ram.accel.raw();
        let max_accel = if accel > 0 {
            f64::from(accel) * DEG
        } else {
            f64::INFINITY
        };
        let limit = self
            .params
            .max_torque_current_a
            .min(max_current_a)
            .min(self.command_limit_a.unwrap_or(f64::INFINITY));
        let current_ref_a = match self.mode {
            ControlMode::Off => 0.0,
            ControlMode::Torque { current_a } => current_a,
            ControlMode::Speed { target_dps } => {
                // The reference ramps at the acceleration limit but never leads the measured
                // speed by more than the loop's steady lag on such a ramp, so that a rotor held
                // by stiction does not wind the loop up (and then catch up faster than allowed).
                // (At least 1 ms of lead, so that a loop without proportional gain still
                // gets a reference to follow.)
                let lead = if max_accel.is_finite() {
                    gains.ramp_lag_s(SPEED_MODE_SETPOINT_WEIGHT).max(1e-3) * max_accel
                } else {
                    f64::INFINITY
                };
                self.loops.speed_ref = ramp(self.loops.speed_ref, target_dps * DEG, max_accel * dt)
                    .clamp(speed - lead, speed + lead);
                let reference = self.loops.speed_ref;
                speed_loop(
                    &mut self.loops,
                    reference,
                    speed,
                    SPEED_MODE_SETPOINT_WEIGHT,
                    &gains,
                    limit,
                    dt,
                )
            }
            ControlMode::Position {
                target_deg,
                max_speed_dps,
            } => {
                let max_speed = max_speed_dps.max(0.0) * DEG;
                let previous_vel = self.loops.profile_vel;
                profile_step(&mut self.loops, target_deg * DEG, max_speed, max_accel, dt);
                let error = self.loops.profile_pos - self.position_rad(plant);
                let reference =
                    (self.loops.profile_vel + gains.angle_kp * error).clamp(-max_speed, max_speed);
                // Feed the profile's acceleration forward through the rotor's own inertia.
                let feedforward =
                    self.rotor_inertia_per_kt * (self.loops.profile_vel - previous_vel) / dt;
                let feedback = speed_loop(
                    &mut self.loops,
                    reference,
                    speed,
                    POSITION_MODE_SETPOINT_WEIGHT,
                    &gains,
                    limit,
                    dt,
                );
                (feedback + feedforward).clamp(-limit, limit)
            }
            ControlMode::Motion {
                position_rad,
                velocity_rad_s,
                kp,
                kd,
                torque_nm,
            } => {
                let ratio = plant.params().gear_ratio;
                let kt_out = plant.params().torque_constant_nm_per_a * ratio;
                let p = self.position_rad(plant) / ratio;
                let v = speed / ratio;
                let torque = kp * (position_rad - p) + kd * (velocity_rad_s - v) + torque_nm;
                (torque / kt_out).clamp(-max_current_a, max_current_a)
            }
        };
        Drive::Current {
            current_ref_a,
            time_constant_s: gains.current_time_constant_s,
        }
    }
}

fn temperature(plant: &Plant) -> Temperature {
    Temperature::from_celsius_saturating(plant.state().winding_temperature_c)
}
