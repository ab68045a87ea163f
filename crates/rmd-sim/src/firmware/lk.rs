//! LK-TECH V2.3x firmware: v1.61's command handling with LK's layouts, scales and motor states.
//!
//! What differs from v1.61 (sources in `rmd_protocol::lk` and `rmd_protocol::dialect_frames`):
//! the status-1 reply (voltage 0.01 V in DATA\[2..=3\], bus current, motor state), the current
//! scale of 0xA1 / 0x280 and of every status-2 reply (MF ±16.5 A, MG ±33 A over ±2048), the u32
//! single-turn angle of 0x94, and the off state: after 0x80 an LK motor "can still reply to
//! control commands, but will not perform actions" until 0x88 (LK-TECH CAN protocol V2.35, motor
//! off / motor on commands). LK motors are on after power-up (same document).

use rmd_protocol::{
    Command, DecodedRequest, Dialect, DialectReply, DialectRequest, DialectStatus1, LkBusCurrent,
    LkCircleAngle, LkMotorState, LkSeries, LkStatus1, LkVoltage, Reply, Request, ScaledCurrent,
    ScaledStatus2,
};

use super::{ControlMode, Firmware, temperature};
use crate::physics::Plant;

impl Firmware {
    /// Handles a request to this motor decoded in the LK dialect of `series`; `None`: ignored.
    /// (A 0x280 frame is handled per motor, with [`lk_torque`](Self::lk_torque).)
    pub(crate) fn handle_lk(
        &mut self,
        request: &DialectRequest,
        series: LkSeries,
        plant: &Plant,
    ) -> Option<DialectReply> {
        let dialect = Dialect::LkV23x(series);
        match *request {
            DialectRequest::Torque { iq_control, .. } => {
                Some(self.lk_torque(iq_control, dialect, plant))
            }
            DialectRequest::Common(DecodedRequest::Single { request, .. }) => {
                if request == Request::MotorRun {
                    self.lk_off = false;
                }
                let reply = self.handle(&request, plant)?;
                if request == Request::MotorOff {
                    self.lk_off = true;
                }
                Some(self.lk_reply(reply, dialect, plant))
            }
            DialectRequest::MultiTorque(_) | DialectRequest::Common(DecodedRequest::Multi(_)) => {
                None
            }
        }
    }

    /// A torque command (0xA1, or this motor's slot of a 0x280 frame): the status-2 reply sampled
    /// before the command, then the command.
    pub(crate) fn lk_torque(
        &mut self,
        iq_control: ScaledCurrent,
        dialect: Dialect,
        plant: &Plant,
    ) -> DialectReply {
        let reply = DialectReply::Status2 {
            command: Command::Torque,
            status: self.lk_status2(dialect, plant),
        };
        self.command(
            ControlMode::Torque {
                current_a: iq_control.amps(),
            },
            plant,
        );
        reply
    }

    /// The LK form of a v1.61 reply.
    fn lk_reply(&self, reply: Reply, dialect: Dialect, plant: &Plant) -> DialectReply {
        if reply.status1().is_some() {
            return DialectReply::Status1 {
                command: reply.command(),
                status: DialectStatus1::Lk(self.lk_status1(plant)),
            };
        }
        if reply.status2().is_some() {
            return DialectReply::Status2 {
                command: reply.command(),
                status: self.lk_status2(dialect, plant),
            };
        }
        if let Reply::ReadSingleTurnAngle { .. } = reply {
            return DialectReply::LkSingleTurnAngle {
                circle_angle: LkCircleAngle::saturating(self.circle_angle_centideg(plant)),
            };
        }
        DialectReply::Common(reply)
    }

    /// Status 1 in the LK layout. The bus current is the electrical power (back-EMF power plus
    /// copper loss) over the supply voltage.
    fn lk_status1(&self, plant: &Plant) -> LkStatus1 {
        let s = plant.state();
        let p = plant.params();
        let power = s.current_a * s.motor_speed_rad_s * p.torque_constant_nm_per_a
            + s.current_a * s.current_a * p.winding_resistance_ohm;
        let bus_current = if s.bus_voltage_v > 0.0 {
            power / s.bus_voltage_v
        } else {
            0.0
        };
        LkStatus1 {
            temperature: temperature(plant),
            voltage: LkVoltage::from_volts_saturating(s.bus_voltage_v),
            bus_current: LkBusCurrent::from_amps_saturating(bus_current),
            motor_state: if self.lk_off {
                LkMotorState::OFF
            } else {
                LkMotorState::ON
            },
            error_state: self.errors,
        }
    }

    /// Status 2 with the series' current scale.
    fn lk_status2(&self, dialect: Dialect, plant: &Plant) -> ScaledStatus2 {
        let v161 = self.status2(plant);
        ScaledStatus2 {
            temperature: v161.temperature,
            iq: ScaledCurrent::from_amps_saturating(plant.state().current_a, dialect.iq_scale()),
            speed: v161.speed,
            encoder: v161.encoder,
        }
    }
}
