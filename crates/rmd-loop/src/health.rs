//! Motor health: what a status-1 reply (0x9A) says of a motor, read in rotation one motor per
//! bus per tick (`loop.health_rotation`), and which of its error flags stop the loop.
//!
//! Every family answers 0x9A with its supply voltage, a temperature and error flags, each in its
//! own layout ([`rmd_protocol::Status1`]): v1.61 and LK-TECH an error byte (bit 0 low voltage,
//! bit 3 over-temperature), MyActuator V3 sixteen bits (stall, low and over voltage, over
//! current, over speed, motor and driver over-temperature, encoder errors, ...). [`MotorFlag`]
//! names each flag the loop faults on, in one vocabulary for every family.

use core::fmt;

use rmd_protocol::{ErrorState, Status1, V3ErrorState};
use serde::Serialize;

/// A motor's latest status-1 reply, as the controller and the telemetry see it. Small on
/// purpose: it rides in every [`JointFeedback`](crate::JointFeedback), copied into every
/// telemetry sample (at most 128 bytes each, copied inline; a unit test keeps it so).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MotorHealth {
    /// Supply voltage, volts.
    pub voltage_volts: f64,
    /// Motor temperature from the status reply, degrees Celsius.
    pub temperature_celsius: f64,
    /// The error flags as the motor sent them, unknown bits included.
    pub error_flags: ErrorFlags,
    /// The tick whose status request this answers: the reading is `tick - requested_tick`
    /// ticks old (at most the number of motors on the bus while every reply comes).
    pub requested_tick: u64,
}

impl MotorHealth {
    /// The reading of `status`, the answer to the request of `requested_tick`.
    pub(crate) fn of(status: &Status1, requested_tick: u64) -> Self {
        Self {
            voltage_volts: status.volts(),
            temperature_celsius: status.temperature().celsius(),
            error_flags: match status {
                Status1::V161(s) => ErrorFlags::Byte(s.error_state),
                Status1::Lk(s) => ErrorFlags::Byte(s.error_state),
                Status1::V3(s) => ErrorFlags::V3(s.error_state),
            },
            requested_tick,
        }
    }
}

/// A status reply's error flags in its family's layout.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum ErrorFlags {
    /// v1.61 and LK-TECH: the error byte (bit 0 low voltage, bit 3 over-temperature).
    Byte(ErrorState),
    /// MyActuator V3: sixteen bits.
    V3(V3ErrorState),
}

impl ErrorFlags {
    /// The flags as sent (the byte, or V3's 16 bits).
    pub const fn raw(self) -> u16 {
        match self {
            ErrorFlags::Byte(e) => e.raw() as u16,
            ErrorFlags::V3(e) => e.raw(),
        }
    }

    /// The flags in the v1.61 error byte's terms (bit 0 low voltage, bit 3 over-temperature),
    /// as telemetry shows them for every family: V3's low-voltage and motor over-temperature
    /// bits mapped there, its others left out (they are in [`raw`](Self::raw)).
    pub fn as_byte(self) -> ErrorState {
        match self {
            ErrorFlags::Byte(e) => e,
            ErrorFlags::V3(e) => {
                let mut byte = ErrorState::NONE;
                if e.contains(V3ErrorState::LOW_VOLTAGE) {
                    byte = byte | ErrorState::LOW_VOLTAGE;
                }
                if e.contains(V3ErrorState::MOTOR_OVER_TEMPERATURE) {
                    byte = byte | ErrorState::OVER_TEMPERATURE;
                }
                byte
            }
        }
    }
}

/// An error flag a motor raised in its status reply (0x9A), in every family's words. Each one
/// is a fault: the firmware protects itself (most turn their output off), and a controller
/// driving the robot on would drive it on one motor short.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MotorFlag {
    /// Supply voltage below the firmware's threshold (v1.61 / LK-TECH bit 0, V3 0x0004).
    UnderVoltage,
    /// Supply voltage above the firmware's threshold (V3 0x0008).
    OverVoltage,
    /// Motor (winding) over-temperature (v1.61 / LK-TECH bit 3, V3 0x1000).
    OverTemperature,
    /// Driver board over-temperature (V3 0x0800).
    DriverOverTemperature,
    /// Motor stall: current above the stall current for the stall time (V3 0x0002).
    Stall,
    /// Phase over-current (V3 0x0010).
    OverCurrent,
    /// Over speed (V3 0x0100).
    OverSpeed,
    /// Power overrun (V3 0x0040).
    PowerOverrun,
    /// Encoder calibration or data error, or a calibration parameter write error (V3 0x2000,
    /// 0x4000, 0x0080).
    Encoder,
}

impl MotorFlag {
    /// The flag's name, as `rmd` prints it.
    pub const fn name(self) -> &'static str {
        match self {
            MotorFlag::UnderVoltage => "under-voltage",
            MotorFlag::OverVoltage => "over-voltage",
            MotorFlag::OverTemperature => "over-temperature",
            MotorFlag::DriverOverTemperature => "driver over-temperature",
            MotorFlag::Stall => "stall",
            MotorFlag::OverCurrent => "over-current",
            MotorFlag::OverSpeed => "over-speed",
            MotorFlag::PowerOverrun => "power overrun",
            MotorFlag::Encoder => "encoder error",
        }
    }

    /// What to check, for a user.
    pub const fn advice(self) -> &'static str {
        match self {
            MotorFlag::UnderVoltage | MotorFlag::OverVoltage => {
                "check its supply (battery, power supply, wiring and connectors)"
            }
            MotorFlag::OverTemperature | MotorFlag::DriverOverTemperature => {
                "let it cool; lower the load, the duty or the current limit"
            }
            MotorFlag::Stall | MotorFlag::OverCurrent | MotorFlag::PowerOverrun => {
                "check what blocks the joint and the current the controller asks"
            }
            MotorFlag::OverSpeed => "check the gains and what drives the joint",
            MotorFlag::Encoder => "recalibrate the motor's encoder (vendor tool) and check it",
        }
    }

    /// The first flag the loop faults on in `status` (in this order: supply, temperature,
    /// stall and current, speed, encoder), or `None`. Bits no manual gives a meaning to are
    /// kept in [`MotorHealth::error_flags`] and are no fault.
    pub fn first_in(status: &Status1) -> Option<Self> {
        match status {
            Status1::V161(s) => Self::of_byte(s.error_state),
            Status1::Lk(s) => Self::of_byte(s.error_state),
            Status1::V3(s) => Self::of_v3(s.error_state),
        }
    }

    fn of_byte(e: ErrorState) -> Option<Self> {
        if e.low_voltage() {
            Some(MotorFlag::UnderVoltage)
        } else if e.over_temperature() {
            Some(MotorFlag::OverTemperature)
        } else {
            None
        }
    }

    fn of_v3(e: V3ErrorState) -> Option<Self> {
        const ORDER: [(V3ErrorState, MotorFlag); 11] = [
            (V3ErrorState::LOW_VOLTAGE, MotorFlag::UnderVoltage),
            (V3ErrorState::OVER_VOLTAGE, MotorFlag::OverVoltage),
            (
                V3ErrorState::MOTOR_OVER_TEMPERATURE,
                MotorFlag::OverTemperature,
            ),
            (
                V3ErrorState::COMPONENT_OVER_TEMPERATURE,
                MotorFlag::DriverOverTemperature,
            ),
            (V3ErrorState::STALL, MotorFlag::Stall),
            (V3ErrorState::OVER_CURRENT, MotorFlag::OverCurrent),
            (V3ErrorState::POWER_OVERRUN, MotorFlag::PowerOverrun),
            (V3ErrorState::OVER_SPEED, MotorFlag::OverSpeed),
            (V3ErrorState::ENCODER_CALIBRATION, MotorFlag::Encoder),
            (V3ErrorState::ENCODER_DATA, MotorFlag::Encoder),
            (V3ErrorState::CALIBRATION_WRITE, MotorFlag::Encoder),
        ];
        if e.is_clear() {
            return None;
        }
        ORDER
            .iter()
            .find(|(bit, _)| e.contains(*bit))
            .map(|&(_, flag)| flag)
    }
}

impl fmt::Display for MotorFlag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{CanFrame, Command, Dialect, LkSeries, V3Firmware};

    fn status(dialect: Dialect, data: [u8; 8]) -> Status1 {
        let frame = CanFrame::new(
            dialect.reply_id(rmd_protocol::MotorId::new(1).unwrap()),
            &data,
        )
        .unwrap();
        dialect
            .decode_reply_to(&frame, Command::ReadStatus1)
            .unwrap()
            .1
            .status1()
            .unwrap()
    }

    #[test]
    fn feedback_stays_small_enough_to_copy_inline() {
        assert!(core::mem::size_of::<Option<MotorHealth>>() <= 32);
        assert!(core::mem::size_of::<crate::JointFeedback>() <= 128);
    }

    #[test]
    fn every_family_names_its_flags_and_reads_its_voltage() {
        // v1.61: DATA[3..=4] 0.1 V, DATA[7] error byte.
        let v161 = status(Dialect::V161, [0x9A, 40, 0, 0xF0, 0x00, 0, 0, 0x01]);
        assert_eq!(MotorFlag::first_in(&v161), Some(MotorFlag::UnderVoltage));
        let h = MotorHealth::of(&v161, 7);
        assert_eq!((h.voltage_volts, h.temperature_celsius), (24.0, 40.0));
        assert_eq!(h.error_flags.raw(), 1);
        let hot = status(Dialect::V161, [0x9A, 90, 0, 0xF0, 0x00, 0, 0, 0x08]);
        assert_eq!(MotorFlag::first_in(&hot), Some(MotorFlag::OverTemperature));
        // An unknown bit alone is no fault; it is kept.
        let odd = status(Dialect::V161, [0x9A, 40, 0, 0xF0, 0x00, 0, 0, 0x20]);
        assert_eq!(MotorFlag::first_in(&odd), None);
        assert_eq!(MotorHealth::of(&odd, 0).error_flags.raw(), 0x20);
        // LK-TECH: voltage in DATA[2..=3] (0.01 V), the same error bits.
        let lk = status(
            Dialect::LkV23x(LkSeries::Mf),
            [0x9A, 35, 0x60, 0x09, 0, 0, 0, 0x08],
        );
        assert_eq!(MotorFlag::first_in(&lk), Some(MotorFlag::OverTemperature));
        assert!((lk.volts() - 24.0).abs() < 1e-9);
        // V3: sixteen bits in DATA[6..=7].
        let v3 = Dialect::MyActuatorV3(V3Firmware::default());
        for (bits, flag) in [
            (0x0002u16, MotorFlag::Stall),
            (0x0004, MotorFlag::UnderVoltage),
            (0x1000, MotorFlag::OverTemperature),
            (0x4000, MotorFlag::Encoder),
            (0x1002, MotorFlag::OverTemperature),
        ] {
            let [lo, hi] = bits.to_le_bytes();
            let s = status(v3, [0x9A, 30, 30, 0, 0xF0, 0x00, lo, hi]);
            assert_eq!(MotorFlag::first_in(&s), Some(flag), "{bits:#06x}");
            let h = MotorHealth::of(&s, 0);
            assert_eq!((h.voltage_volts, h.error_flags.raw()), (24.0, bits));
            assert_eq!(
                h.error_flags.as_byte().low_voltage(),
                flag == MotorFlag::UnderVoltage
            );
        }
        let clear = status(v3, [0x9A, 30, 30, 0, 0xF0, 0x00, 0, 0]);
        assert_eq!(MotorFlag::first_in(&clear), None);
    }
}
