//! MyActuator V3 firmware, far enough to be identified and to show what a v1.61 host's frames do
//! to it (layouts: `rmd_protocol::v3`, from MyActuator's Servo Motor Control Protocol V4.3).
//!
//! Answered (on `0x240 + id`): 0x9A, 0x9C, 0x92, 0xB5, 0x80, 0x81, 0xA1 (0.01 A per LSB).
//! Speeds and angles in V3 replies are the output shaft's (motor side over the gear ratio).
//! Every other command byte is ignored without a reply. A 0x280 frame is one of these commands
//! for every V3 motor on the bus (handled by the bus side, per motor).

use rmd_protocol::v3::{V3Command, V3ErrorState, V3Reply, V3Request, V3Status1, V3Status2};
use rmd_protocol::{CurrentScale, ErrorState, Request, ScaledCurrent, Speed, Voltage};

use super::{ControlMode, DEG, Firmware, temperature};
use crate::physics::Plant;

/// The model a simulated V3 motor reports to 0xB5.
pub const SIM_V3_MODEL: [u8; 7] = *b"RMD-SIM";

impl Firmware {
    /// Handles a V3 request; `None`: ignored (not answered).
    pub(crate) fn handle_v3(&mut self, request: &V3Request, plant: &Plant) -> Option<V3Reply> {
        Some(match *request {
            V3Request::ReadStatus1 => V3Reply::Status1(self.v3_status1(plant)),
            V3Request::ReadStatus2 => V3Reply::Status2 {
                command: V3Command::ReadStatus2,
                status: self.v3_status2(plant),
            },
            V3Request::ReadMultiTurnAngle => V3Reply::MultiTurnAngle {
                centidegrees: (self.motor_angle_centideg(plant) as f64 / gear_ratio(plant))
                    .round()
                    .clamp(f64::from(i32::MIN), f64::from(i32::MAX))
                    as i32,
            },
            V3Request::ReadModel => V3Reply::Model(SIM_V3_MODEL),
            V3Request::MotorOff => {
                self.handle(&Request::MotorOff, plant)?;
                V3Reply::MotorOff
            }
            V3Request::MotorStop => {
                self.handle(&Request::MotorStop, plant)?;
                V3Reply::MotorStop
            }
            V3Request::Torque { iq_control } => {
                let reply = V3Reply::Status2 {
                    command: V3Command::Torque,
                    status: self.v3_status2(plant),
                };
                self.command(
                    ControlMode::Torque {
                        current_a: iq_control.amps(),
                    },
                    plant,
                );
                reply
            }
        })
    }

    fn v3_status1(&self, plant: &Plant) -> V3Status1 {
        let mut error = 0u16;
        if self.errors.contains(ErrorState::LOW_VOLTAGE) {
            error |= V3ErrorState::LOW_VOLTAGE.raw();
        }
        if self.errors.contains(ErrorState::OVER_TEMPERATURE) {
            error |= V3ErrorState::MOTOR_OVER_TEMPERATURE.raw();
        }
        V3Status1 {
            temperature: temperature(plant),
            mos_temperature: temperature(plant),
            brake_released: true,
            voltage: Voltage::from_volts_saturating(plant.state().bus_voltage_v),
            error_state: V3ErrorState::from_raw(error),
        }
    }

    fn v3_status2(&self, plant: &Plant) -> V3Status2 {
        let s = plant.state();
        let ratio = gear_ratio(plant);
        V3Status2 {
            temperature: temperature(plant),
            iq: ScaledCurrent::from_amps_saturating(s.current_a, CurrentScale::MYACTUATOR_V3_IQ),
            speed: Speed::from_dps_saturating(s.motor_speed_rad_s / DEG / ratio),
            shaft_degrees: (self.motor_angle_centideg(plant) as f64 / 100.0 / ratio)
                .round()
                .clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16,
        }
    }
}

fn gear_ratio(plant: &Plant) -> f64 {
    plant.params().gear_ratio
}
