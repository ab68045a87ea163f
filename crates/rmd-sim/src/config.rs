//! Configuration: firmware settings, one motor, the bus, a whole simulation.

use core::time::Duration;

use rmd_protocol::{
    Accel, Dialect, EncoderValue, EncoderWidth, FirmwareDate, MotorId, MotorMaxTorque, PidParams,
    V3Firmware, WatchdogTimeout,
};

use crate::error::ConfigError;
use crate::family::{FirmwareFamily, FirmwareTraps};
use crate::fault::FaultRule;
use crate::medium::WireTiming;
use crate::params::{LoadParams, MotorParams, non_negative};

/// Which command byte the motor puts in its reply to 0x9B (clear error flags).
///
/// The spec's table for the 0x9B reply shows DATA\[0\] = 0x9A; the reading notes take that as a
/// slip (the reply echoes 0x9B) but ask clients to tolerate 0x9A. The simulator can send either,
/// so clients can be tested against both.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum ClearErrorReply {
    /// DATA\[0\] = 0x9B, the echo of the request (the intended reading).
    #[default]
    Echo,
    /// DATA\[0\] = 0x9A, as the spec's table shows.
    Status1Code,
}

/// What a MyActuator V3 firmware knows beyond v1.61's settings (used by
/// [`FirmwareFamily::MyActuatorV3`] motors only).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct V3Params {
    /// The version date 0xB2 reports; it decides the V4.3 / V4.4 layouts and motion-mode
    /// ranges ([`FirmwareDate::revision`]). Default 2025070202, the firmware reported from real
    /// X4-64 and X4-36 motors (github.com/2b-t/myactuator_rmd issues 24 and 28): V4.3.
    pub firmware_date: FirmwareDate,
    /// The model string 0xB5 reports, up to 15 ASCII characters (NUL-padded): the V4.3 form
    /// answers the first 7, the V4.4 form 5 per index. Default `RMD-SIM`.
    pub model: [u8; 15],
    /// The maximum torque at the output, N·m: the motion-mode torque range of V4.4 firmware.
    /// Default 24 N·m `[estimate]` (the V4.3 range).
    pub max_torque_nm: f64,
    /// The rated current, A: `maxTorque` of 0xA2 is a percentage of it. Default 4.3 A (the
    /// X8 V2 of the default motor, `[X8V2]` in `params`).
    pub rated_current_a: f64,
    /// Whether a holding brake is fitted: it is locked at power-up and after a watchdog trip,
    /// and holds the rotor until 0x77 releases it ("this command cannot open the brake
    /// directly", V4.4 §2.18). Without one, 0x77 / 0x78 only change the state 0x9A reports.
    /// Default false.
    pub has_brake: bool,
    /// How long the motor is unreachable after 0x76 (system reset) before it runs as after a
    /// power-up. Default 1.12 s, measured by github.com/almond-bot/axol (`myactuator.py`,
    /// "Measured reboot time is ~1.12s").
    pub reboot_time: Duration,
    /// The communication-interruption protection time in the motor's ROM at power-up (0xB3,
    /// as `rmd watchdog` writes it). Default off.
    pub watchdog: WatchdogTimeout,
}

/// The default V3 model string.
const SIM_MODEL: [u8; 15] = *b"RMD-SIM\0\0\0\0\0\0\0\0";

impl Default for V3Params {
    fn default() -> Self {
        Self {
            firmware_date: FirmwareDate::from_raw(2_025_070_202),
            model: SIM_MODEL,
            max_torque_nm: 24.0,
            rated_current_a: 4.3,
            has_brake: false,
            reboot_time: Duration::from_millis(1120),
            watchdog: WatchdogTimeout::OFF,
        }
    }
}

impl V3Params {
    /// The firmware as the codec needs it (date and maximum torque).
    pub fn firmware(&self) -> V3Firmware {
        let firmware = V3Firmware::dated(self.firmware_date);
        match MotorMaxTorque::from_nm(self.max_torque_nm) {
            Ok(max) => firmware.with_max_torque(max),
            Err(_) => firmware,
        }
    }
}

/// The firmware's settings: what the manufacturer's configuration tool ("host computer") sets
/// and what is in ROM at power-up.
///
/// Angles and speeds are motor side (the encoder is on the motor), as in every frame.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FirmwareParams {
    /// Encoder resolution. Default 14 bits `[spec]`.
    pub encoder_width: EncoderWidth,
    /// PID gains in ROM (loaded to RAM at power-up; 0x32 writes both). Default angle 100/100,
    /// speed 50/40, iq 50/50 `[estimate]`: shipped values differ between firmware versions;
    /// these make the simulated loops well damped with the default motor (see the `control`
    /// module for how the raw gains map to physical ones).
    pub pid: PidParams,
    /// Acceleration limit in effect at power-up (0x34 changes the RAM copy), motor side, dps/s.
    /// Zero or negative: no limit. Default 36 000 dps/s (100 turns/s² at the motor, 11 at the
    /// output) `[estimate]`.
    pub accel: Accel,
    /// Encoder zero offset in ROM (0x19 writes it, effective after a power cycle). Default 0.
    pub encoder_offset: EncoderValue,
    /// "Max Torque Current": limit of the torque current in the speed and position modes, A.
    /// Default 32 A (the full command range) `[estimate]`.
    pub max_torque_current_a: f64,
    /// "Max Speed": speed limit of 0xA3 and 0xA5, motor side, dps. Default 7200 dps (20 turns/s
    /// at the motor, 133 rpm at the output, below the rated 170 rpm) `[estimate]`.
    pub max_speed_dps: f64,
    /// "Max Angle": 0xA3 / 0xA4 targets are clamped to ±this, motor side, degrees. Default none.
    pub max_angle_deg: Option<f64>,
    /// Low-voltage protection: the flag is raised when the supply falls below this, V. Default
    /// 36 V (75 % of the 48 V nominal) `[estimate]`.
    pub low_voltage_threshold_v: f64,
    /// Low-voltage hysteresis: the cause persists (a clear fails) until the supply is back
    /// above threshold + this, V. Default 1 V `[estimate]`.
    pub low_voltage_hysteresis_v: f64,
    /// Over-temperature protection: the flag is raised when the winding reaches this, °C.
    /// Default 80 °C `[estimate]`.
    pub over_temperature_threshold_c: f64,
    /// Over-temperature hysteresis: the cause persists (a clear fails) until the winding is
    /// back below threshold - this, °C. Default 5 °C `[estimate]`.
    pub over_temperature_hysteresis_c: f64,
    /// Command byte of the reply to 0x9B.
    pub clear_error_reply: ClearErrorReply,
    /// The protocol family the firmware speaks. Default v1.61.
    pub family: FirmwareFamily,
    /// What a MyActuator V3 firmware adds (date, model, brake, reboot time).
    pub v3: V3Params,
    /// Firmware-state traps reported from real motors. Default: none.
    pub traps: FirmwareTraps,
    /// Replies leave in the order the requests came: a reply held back (a late-reply fault)
    /// holds the motor's later replies back too, as firmware handling one request at a time
    /// does. Default: true.
    pub in_order_replies: bool,
}

impl Default for FirmwareParams {
    fn default() -> Self {
        Self {
            encoder_width: EncoderWidth::DEFAULT,
            pid: PidParams {
                angle_pid_kp: 100,
                angle_pid_ki: 100,
                speed_pid_kp: 50,
                speed_pid_ki: 40,
                iq_pid_kp: 50,
                iq_pid_ki: 50,
            },
            accel: Accel::saturating(36_000),
            encoder_offset: EncoderValue::from_raw(0),
            max_torque_current_a: 32.0,
            max_speed_dps: 7_200.0,
            max_angle_deg: None,
            low_voltage_threshold_v: 36.0,
            low_voltage_hysteresis_v: 1.0,
            over_temperature_threshold_c: 80.0,
            over_temperature_hysteresis_c: 5.0,
            clear_error_reply: ClearErrorReply::Echo,
            family: FirmwareFamily::V161,
            v3: V3Params::default(),
            traps: FirmwareTraps::default(),
            in_order_replies: true,
        }
    }
}

impl FirmwareParams {
    /// Makes the firmware speak `dialect`: its family, and for MyActuator V3 its firmware date
    /// and maximum torque when the dialect knows them.
    ///
    /// ```
    /// use rmd_protocol::{Dialect, FirmwareDate, V3Firmware};
    /// use rmd_sim::{FirmwareFamily, FirmwareParams};
    /// let mut firmware = FirmwareParams::default();
    /// firmware.speak(Dialect::MyActuatorV3(V3Firmware::dated(FirmwareDate::from_raw(2026042402))));
    /// assert_eq!(firmware.family, FirmwareFamily::MyActuatorV3);
    /// assert_eq!(firmware.v3.firmware_date.raw(), 2026042402);
    /// ```
    pub fn speak(&mut self, dialect: Dialect) {
        self.family = match dialect {
            Dialect::V161 => FirmwareFamily::V161,
            Dialect::LkV23x(series) => FirmwareFamily::LkV23x(series),
            Dialect::MyActuatorV3(firmware) => {
                if let Some(date) = firmware.date {
                    self.v3.firmware_date = date;
                }
                if let Some(max) = firmware.max_torque {
                    self.v3.max_torque_nm = max.nm();
                }
                FirmwareFamily::MyActuatorV3
            }
        };
    }

    /// Checks every value is meaningful.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.encoder_offset.check(self.encoder_width).map_err(|_| {
            ConfigError::InvalidParameter {
                name: "firmware.encoder_offset",
                value: f64::from(self.encoder_offset.raw()),
                expected: "a value below the encoder's counts per turn",
            }
        })?;
        non_negative("firmware.max_torque_current_a", self.max_torque_current_a)?;
        non_negative("firmware.max_speed_dps", self.max_speed_dps)?;
        if let Some(a) = self.max_angle_deg {
            non_negative("firmware.max_angle_deg", a)?;
        }
        non_negative(
            "firmware.low_voltage_threshold_v",
            self.low_voltage_threshold_v,
        )?;
        non_negative(
            "firmware.low_voltage_hysteresis_v",
            self.low_voltage_hysteresis_v,
        )?;
        non_negative(
            "firmware.over_temperature_hysteresis_c",
            self.over_temperature_hysteresis_c,
        )?;
        if !(self.v3.max_torque_nm.is_finite() && self.v3.max_torque_nm > 0.0) {
            return Err(ConfigError::InvalidParameter {
                name: "firmware.v3.max_torque_nm",
                value: self.v3.max_torque_nm,
                expected: "a positive number",
            });
        }
        non_negative("firmware.v3.rated_current_a", self.v3.rated_current_a)?;
        if !self.over_temperature_threshold_c.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "firmware.over_temperature_threshold_c",
                value: self.over_temperature_threshold_c,
                expected: "a finite number",
            });
        }
        Ok(())
    }
}

/// One simulated motor: its id, physics, load, firmware settings and reply latency.
///
/// ```
/// use rmd_protocol::MotorId;
/// use rmd_sim::{GravityLink, SimMotorConfig};
/// let mut knee = SimMotorConfig::new(MotorId::new(3).unwrap());
/// knee.load.gravity = Some(GravityLink { mass_kg: 1.5, length_m: 0.25, angle_offset_deg: 90.0 });
/// knee.motor.gear_ratio = 6.0;
/// knee.validate().unwrap();
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SimMotorConfig {
    /// The motor's id (it answers on 0x140 + id, MyActuator V3 firmware on 0x240 + id; ids
    /// 1..=4 also answer 0x280, every V3 motor answers a 0x280 command).
    pub id: MotorId,
    /// Physical parameters.
    pub motor: MotorParams,
    /// What it drives.
    pub load: LoadParams,
    /// Firmware settings.
    pub firmware: FirmwareParams,
    /// Output shaft angle at power-up, degrees.
    pub initial_output_angle_deg: f64,
    /// Time from receiving a request to the reply being ready to send. Default 200 µs (from the
    /// issue; users report round trips of ~0.25 ms to ~2 ms across motor families and adapters,
    /// e.g. 2b-t/myactuator_rmd issue 23).
    pub turnaround: Duration,
    /// Uniform random extra turnaround, 0..=this, drawn per reply from the seeded stream.
    /// Default 20 µs `[estimate]`.
    pub turnaround_jitter: Duration,
}

impl SimMotorConfig {
    /// An RMD-X8-class motor with id `id` and every default.
    pub fn new(id: MotorId) -> Self {
        Self {
            id,
            motor: MotorParams::default(),
            load: LoadParams::default(),
            firmware: FirmwareParams::default(),
            initial_output_angle_deg: 0.0,
            turnaround: Duration::from_micros(200),
            turnaround_jitter: Duration::from_micros(20),
        }
    }

    /// Checks every value is meaningful.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.motor.validate()?;
        self.load.validate()?;
        self.firmware.validate()?;
        if !self.initial_output_angle_deg.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "initial_output_angle_deg",
                value: self.initial_output_angle_deg,
                expected: "a finite number",
            });
        }
        Ok(())
    }
}

/// The simulated wire and the host's queues.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct SimBusConfig {
    /// Frame timing: a bit rate (default 1 Mbit/s) or instant.
    pub timing: WireTiming,
    /// Depth of the host's transmit queue, frames. Default 10 (SocketCAN's default
    /// `txqueuelen` for CAN interfaces).
    pub tx_queue_len: usize,
    /// Depth of the host's receive queue, frames and events; beyond it frames are lost and
    /// the client gets [`BusEvent::RxOverflow`](rmd_bus::BusEvent::RxOverflow). Default 256
    /// `[estimate]`: about what the default socket receive buffer (`rmem_default`, 208 KiB)
    /// holds of CAN frames.
    pub rx_queue_len: usize,
    /// Transmit mailboxes per motor. Default 3 (common MCU CAN controllers, e.g. STM32 bxCAN).
    pub motor_mailboxes: usize,
}

impl Default for SimBusConfig {
    fn default() -> Self {
        Self {
            timing: WireTiming::Bitrate(1_000_000),
            tx_queue_len: 10,
            rx_queue_len: 256,
            motor_mailboxes: 3,
        }
    }
}

impl SimBusConfig {
    /// Checks every value is meaningful.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let check = |name, v: usize, max: usize, expected| {
            if v == 0 || v > max {
                Err(ConfigError::InvalidParameter {
                    name,
                    value: v as f64,
                    expected,
                })
            } else {
                Ok(())
            }
        };
        check("bus.tx_queue_len", self.tx_queue_len, 1 << 16, "1..=65536")?;
        check(
            "bus.rx_queue_len",
            self.rx_queue_len,
            1 << 20,
            "1..=1048576",
        )?;
        check("bus.motor_mailboxes", self.motor_mailboxes, 64, "1..=64")?;
        if self.timing == WireTiming::Bitrate(0) {
            return Err(ConfigError::InvalidParameter {
                name: "bus.timing bitrate",
                value: 0.0,
                expected: "a bit rate > 0 bit/s",
            });
        }
        Ok(())
    }
}

/// A whole simulation: the bus, its motors, the fault rules and the seed.
///
/// ```
/// use rmd_sim::SimConfig;
/// let config = SimConfig::with_motors(4).seed(7);
/// assert_eq!(config.motors.len(), 4);
/// let fast = SimConfig::with_motors(4).instant();
/// assert_eq!(fast.motors[0].turnaround, core::time::Duration::ZERO);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// The wire and the host's queues.
    pub bus: SimBusConfig,
    /// The motors (ids must be unique).
    pub motors: Vec<SimMotorConfig>,
    /// Fault-injection rules, evaluated in order.
    pub faults: Vec<FaultRule>,
    /// Seed of every pseudo-random draw (faults, turnaround jitter).
    pub seed: u64,
}

impl SimConfig {
    /// Motors with ids 1..=`count` (at most 32), every default, on a 1 Mbit/s bus, seed 0.
    pub fn with_motors(count: u8) -> Self {
        Self {
            bus: SimBusConfig::default(),
            motors: (1..=count.min(MotorId::MAX))
                .filter_map(|id| MotorId::new(id).ok())
                .map(SimMotorConfig::new)
                .collect(),
            faults: Vec::new(),
            seed: 0,
        }
    }

    /// Sets the seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Sets the firmware family of every motor (e.g. to test identification on a bus of
    /// MyActuator V3 motors).
    ///
    /// ```
    /// use rmd_sim::{FirmwareFamily, SimConfig};
    /// let config = SimConfig::with_motors(2).firmware_family(FirmwareFamily::MyActuatorV3);
    /// assert!(config.motors.iter().all(|m| m.firmware.family == FirmwareFamily::MyActuatorV3));
    /// ```
    pub fn firmware_family(mut self, family: FirmwareFamily) -> Self {
        for m in &mut self.motors {
            m.firmware.family = family;
        }
        self
    }

    /// Adds a fault rule.
    pub fn fault(mut self, rule: FaultRule) -> Self {
        self.faults.push(rule);
        self
    }

    /// The "instant" configuration, for overhead benchmarks of the code around the bus: frames
    /// take no wire time and motors answer with zero turnaround and no jitter, so everything
    /// happens at the instant it is sent (in virtual time the clock does not move; in real time
    /// replies are ready as soon as the request is sent). Physics and faults still run.
    pub fn instant(mut self) -> Self {
        self.bus.timing = WireTiming::Instant;
        for m in &mut self.motors {
            m.turnaround = Duration::ZERO;
            m.turnaround_jitter = Duration::ZERO;
        }
        self
    }

    /// Checks the whole configuration.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.bus.validate()?;
        validate_motors(&self.motors)?;
        for (i, rule) in self.faults.iter().enumerate() {
            rule.validate(i)?;
        }
        Ok(())
    }
}

pub(crate) fn validate_motors(motors: &[SimMotorConfig]) -> Result<(), ConfigError> {
    let mut seen = 0u64;
    for m in motors {
        m.validate()?;
        let bit = 1u64 << m.id.get();
        if seen & bit != 0 {
            return Err(ConfigError::DuplicateMotor { id: m.id.get() });
        }
        seen |= bit;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicate_ids_and_bad_values_are_rejected() {
        let mut c = SimConfig::with_motors(2);
        c.validate().unwrap();
        c.motors[1].id = c.motors[0].id;
        assert_eq!(c.validate(), Err(ConfigError::DuplicateMotor { id: 1 }));

        let mut c = SimConfig::with_motors(1);
        c.motors[0].firmware.encoder_offset = EncoderValue::from_raw(16_384);
        assert!(c.validate().is_err());

        let mut c = SimConfig::with_motors(1);
        c.bus.tx_queue_len = 0;
        assert!(c.validate().is_err());
        c.bus.tx_queue_len = 10;
        c.bus.motor_mailboxes = usize::MAX;
        assert!(c.validate().is_err());
        c.bus.motor_mailboxes = 3;
        c.bus.tx_queue_len = 1;
        c.bus.timing = WireTiming::Bitrate(0);
        assert!(c.validate().is_err());
    }

    #[test]
    fn at_most_32_motors() {
        assert_eq!(SimConfig::with_motors(40).motors.len(), 32);
        assert_eq!(SimConfig::with_motors(0).motors.len(), 0);
    }
}
