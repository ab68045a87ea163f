//! MyActuator V3 firmware (MyActuator "Servo Motor Control Protocol", applicable driver V3,
//! V4.3 and V4.4; layouts: `rmd_protocol`'s V3 dialect).
//!
//! What a V3 motor does here, beyond v1.61's handling of the commands it shares:
//!
//! - **Units.** Speeds and angles are the output shaft's: 0xA2 commands output dps, 0xA4 output
//!   degrees (V4.4 §2.19, §2.20), status 2 reports output dps and whole output degrees (§2.14),
//!   0x92 the output's multi-turn angle (§2.11); 0x94 is the motor encoder's single turn under
//!   V4.3 (§2.13) and the output's ±180° under V4.4 (§2.12). Currents are 0.01 A.
//! - **0x81** brings the speed to zero and holds the position ("without changing the
//!   closed-loop mode the motor is running in", V4.4 §2.17): the simulator holds the position
//!   where the command found it with its position loop.
//! - **0xA2's `maxTorque`** (percent of the rated current, [`V3Params::rated_current_a`]) limits
//!   the current while the speed command runs; 0, or a limit above the max torque current, sets
//!   none (V4.4 §2.19).
//! - **Brake** (0x77 / 0x78, V4.4 §2.28 / §2.29): the state 0x9A reports in DATA\[3\]. With a
//!   brake fitted ([`V3Params::has_brake`]) it is locked at power-up and the output stays off
//!   while it is locked: release it before 0xA1 (V4.4 §2.18). The simulated brake only disables
//!   the output; it adds no holding torque against a load.
//! - **Watchdog** (0xB3, V4.4 §2.32): see [`SimMotor`](crate::SimMotor) (it is about time).
//! - **Function control** (0x20, V4.4 §2.36): echoed; the CAN ID filter (index 2) makes the
//!   motor deaf to 0x280 frames ("once enabled, the 0x280 multi-motor command cannot be used",
//!   §2.36 example 2). The other indexes are stored, not acted on (a new CAN ID, index 5, is not
//!   applied).
//! - **Reset** (0x76, V4.4 §2.27): no reply; the motor is unreachable for
//!   [`V3Params::reboot_time`], then runs as after a power-up (RAM lost, ROM kept: the
//!   protection time, the CAN ID filter).
//! - **Errors.** Undervoltage and motor over-temperature are reported as 0x0004 and 0x1000
//!   (V4.4 §2.13) and clear themselves once their cause is gone (level 2, §7); there is no
//!   clear-error command.
//! - **Motion mode** (0x400 + id, V4.4 §4): `IqRef = [kp (p_des - p) + kd (v_des - v) + t_ff] /
//!   KT_OUT` at the output shaft, ranges by firmware date ([`V3Params::firmware_date`]); the
//!   reply on 0x500 + id carries the output's position (from the zero, multi-turn), velocity and
//!   torque (current × the output torque constant), clamped to the ranges.
//!
//! [`V3Params::rated_current_a`]: crate::V3Params::rated_current_a
//! [`V3Params::has_brake`]: crate::V3Params::has_brake
//! [`V3Params::reboot_time`]: crate::V3Params::reboot_time
//! [`V3Params::firmware_date`]: crate::V3Params::firmware_date

use rmd_protocol::{
    BrakeState, ErrorState, MitCommand, MitFeedback, ModelPart, ModelText, MotorAngle, OutputAngle,
    Reply, Request, ScaledCurrent, Speed, Status2, StatusPosition, V3CircleAngle, V3ErrorState,
    V3Function, V3Revision, V3Status1, Voltage, WatchdogTimeout,
};

use super::{ControlMode, DEG, Firmware, temperature};
use crate::config::V3Params;
use crate::physics::Plant;

/// The first seven characters of the default model string, what 0xB5 answers in V4.3's form.
pub const SIM_V3_MODEL: [u8; 7] = *b"RMD-SIM";

/// What a V3 firmware keeps beyond v1.61's state.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct V3State {
    /// The brake is locked (0x78, a watchdog trip, power-up with a brake fitted).
    pub(crate) brake_locked: bool,
    /// The communication-interruption protection time (ROM).
    pub(crate) watchdog: WatchdogTimeout,
    /// The CAN ID filter (flash): with it on, 0x280 frames are not received.
    pub(crate) can_id_filter: bool,
    /// The value last written to each function index 1..=8 (index 0 unused).
    pub(crate) functions: [u32; 9],
    /// 0x76 was received: the motor reboots after answering nothing.
    pub(crate) reset_requested: bool,
}

impl V3State {
    pub(crate) fn new(params: &V3Params) -> Self {
        Self {
            brake_locked: params.has_brake,
            watchdog: params.watchdog,
            can_id_filter: false,
            functions: [0; 9],
            reset_requested: false,
        }
    }

    /// A power-up or reset: RAM lost, ROM (protection time, functions) kept.
    pub(crate) fn power_up(&mut self, params: &V3Params) {
        self.brake_locked = params.has_brake;
        self.reset_requested = false;
    }

    /// Whether a locked brake keeps the output off.
    pub(crate) fn holds_output(&self, params: &V3Params) -> bool {
        params.has_brake && self.brake_locked
    }
}

impl Firmware {
    /// Handles what V3 does differently from v1.61: `Some(reply)` (or `Some(None)`, no reply)
    /// when handled here, `None` to handle it as every family does.
    pub(super) fn handle_v3(&mut self, request: &Request, plant: &Plant) -> Option<Option<Reply>> {
        let ratio = plant.params().gear_ratio;
        Some(Some(match *request {
            Request::ReadMultiTurnAngle => Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::saturating(
                    (self.motor_angle_centideg(plant) as f64 / ratio)
                        .round()
                        .clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i64,
                ),
            },
            Request::ReadSingleTurnAngle
                if self.params.v3.firmware_date.revision() == V3Revision::V4_4 =>
            {
                let output = self.motor_angle_centideg(plant) as f64 / ratio;
                let wrapped = (output + 18_000.0).rem_euclid(36_000.0) - 18_000.0;
                Reply::V3SingleTurnAngle {
                    circle_angle: V3CircleAngle::saturating(wrapped.round() as i64),
                }
            }
            Request::MotorStop => {
                let here = self.motor_angle_centideg(plant) as f64 / 100.0;
                self.command(self.position(here, self.params.max_speed_dps), plant);
                Reply::MotorStop
            }
            Request::Speed {
                speed_control,
                max_torque,
            } => {
                let reply = self.speed(speed_control.dps() * ratio, plant);
                let limit = f64::from(max_torque.raw()) / 100.0 * self.params.v3.rated_current_a;
                if max_torque.is_set() && limit <= self.params.max_torque_current_a {
                    self.command_limit_a = Some(limit);
                }
                reply
            }
            Request::Position2 {
                max_speed,
                angle_control,
            } => self.position_2(
                angle_control.degrees() * ratio,
                max_speed.dps() * ratio,
                plant,
            ),
            Request::ReadFirmwareDate => Reply::ReadFirmwareDate(self.params.v3.firmware_date),
            Request::ReadModel { part } => Reply::ReadModel(model_text(&self.params.v3, part)),
            Request::SetWatchdog { timeout } => {
                self.v3.watchdog = timeout;
                Reply::SetWatchdog { timeout }
            }
            Request::FunctionControl(f) => {
                self.v3.functions[usize::from(f.function.index())] = f.value;
                if f.function == V3Function::CanIdFilter {
                    self.v3.can_id_filter = f.value != 0;
                }
                Reply::FunctionControl(f)
            }
            Request::Reset => {
                self.v3.reset_requested = true;
                return Some(None);
            }
            Request::BrakeRelease => {
                self.v3.brake_locked = false;
                Reply::BrakeRelease
            }
            Request::BrakeLock => {
                self.v3.brake_locked = true;
                Reply::BrakeLock
            }
            _ => return None,
        }))
    }

    /// A motion-mode command: the feedback sampled before it, then the command.
    pub(crate) fn handle_mit(
        &mut self,
        command: &MitCommand,
        plant: &Plant,
    ) -> Option<MitFeedback> {
        let s = plant.state();
        let p = plant.params();
        let ratio = p.gear_ratio;
        let feedback = MitFeedback::from_si_saturating(
            command.ranges(),
            self.position_rad(plant) / ratio,
            s.motor_speed_rad_s / ratio,
            s.current_a * p.torque_constant_nm_per_a * ratio,
        )
        .ok()?;
        self.command(
            ControlMode::Motion {
                position_rad: command.position_rad(),
                velocity_rad_s: command.velocity_rad_s(),
                kp: command.kp(),
                kd: command.kd(),
                torque_nm: command.torque_nm(),
            },
            plant,
        );
        Some(feedback)
    }

    /// The communication-interruption protection tripped: "the drive cuts off the output and
    /// locks the brake" (V4.4 §2.32).
    pub(crate) fn watchdog_trip(&mut self) {
        self.mode = ControlMode::Off;
        self.stopped = false;
        self.v3.brake_locked = true;
    }

    /// V3 status 1: DATA\[2\] is the driver's (MOS) temperature, simulated as the winding's.
    pub(super) fn v3_status1(&self, plant: &Plant) -> V3Status1 {
        let mut error = V3ErrorState::NONE;
        if self.errors.contains(ErrorState::LOW_VOLTAGE) {
            error = error | V3ErrorState::LOW_VOLTAGE;
        }
        if self.errors.contains(ErrorState::OVER_TEMPERATURE) {
            error = error | V3ErrorState::MOTOR_OVER_TEMPERATURE;
        }
        V3Status1 {
            temperature: temperature(plant),
            mos_temperature: temperature(plant),
            brake: if self.v3.brake_locked {
                BrakeState::LOCKED
            } else {
                BrakeState::RELEASED
            },
            voltage: Voltage::from_volts_saturating(plant.state().bus_voltage_v),
            error_state: error,
        }
    }

    /// V3 status 2: the output shaft's speed (dps) and angle (whole degrees from the zero).
    pub(super) fn v3_status2(&self, plant: &Plant, iq: ScaledCurrent) -> Status2 {
        let s = plant.state();
        let ratio = plant.params().gear_ratio;
        Status2 {
            temperature: temperature(plant),
            iq,
            speed: Speed::from_dps_saturating(s.motor_speed_rad_s / DEG / ratio),
            position: StatusPosition::OutputDegrees(OutputAngle::saturating(
                (self.motor_angle_centideg(plant) as f64 / 100.0 / ratio).round() as i64,
            )),
        }
    }
}

/// The model characters a 0xB5 request asks for: the first seven (V4.3's form) or five of
/// them (V4.4's).
fn model_text(params: &V3Params, part: ModelPart) -> ModelText {
    match part {
        ModelPart::Whole => {
            let mut chars = [0u8; 7];
            chars.copy_from_slice(&params.model[..7]);
            ModelText::Whole(chars)
        }
        ModelPart::Chars(index) => {
            let from = 5 * usize::from(index.get() - 1);
            let mut chars = [0u8; 5];
            chars.copy_from_slice(&params.model[from..from + 5]);
            ModelText::Chars { index, chars }
        }
    }
}
