//! LK-TECH V2.3x firmware: v1.61's command handling with LK's layouts, scales and motor states.
//!
//! What differs from v1.61 (sources in `rmd_protocol::LkStatus1` and `rmd_protocol::Dialect`):
//! the status-1 reply (voltage 0.01 V in DATA\[2..=3\], bus current, motor state), the current
//! scale of 0xA1 / 0x280 and of every status-2 reply (MF ±16.5 A, MG ±33 A over ±2048), the u32
//! single-turn angle of 0x94, and the off state: after 0x80 an LK motor "can still reply to
//! control commands, but will not perform actions" until 0x88 (LK-TECH CAN protocol V2.35, motor
//! off / motor on commands; `Firmware::handle`). LK motors are on after power-up (same
//! document).

use rmd_protocol::{LkBusCurrent, LkCircleAngle, LkMotorState, LkStatus1, LkVoltage, Reply};

use super::{Firmware, temperature};
use crate::physics::Plant;

impl Firmware {
    /// Status 1 in the LK layout. The bus current is the electrical power (back-EMF power plus
    /// copper loss) over the supply voltage.
    pub(super) fn lk_status1(&self, plant: &Plant) -> LkStatus1 {
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

    /// The 0x94 reply in the LK layout (u32, 0.01°).
    pub(super) fn lk_single_turn_angle(&self, plant: &Plant) -> Reply {
        Reply::LkSingleTurnAngle {
            circle_angle: LkCircleAngle::saturating(self.circle_angle_centideg(plant)),
        }
    }
}
