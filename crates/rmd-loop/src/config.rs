//! The robot description: buses, motors and loop settings, from a TOML file or built in code,
//! validated with errors that name the offending key.
//!
//! ```toml
//! [loop]
//! rate_hz = 1000.0
//! cpu = 1
//! fifo_priority = 80
//! spin_margin_us = 50
//!
//! [[bus]]
//! interface = "can0"
//! bitrate = 1000000
//!
//! [[bus.motor]]
//! id = 1
//! name = "hip"
//! gear_ratio = 6.0
//! current_limit_amps = 8.0
//! torque_constant_nm_per_amp = 0.52
//! ```
//!
//! The same in code:
//!
//! ```
//! use rmd_loop::config::{BusConfig, MotorConfig, RobotConfig};
//! let robot = RobotConfig::new(1000.0)
//!     .with_bus(BusConfig::new("can0").with_motor(MotorConfig::new(1).gear_ratio(6.0).current_limit(8.0)));
//! robot.validate().unwrap();
//! assert_eq!(robot.motor_count(), 1);
//! ```

use core::time::Duration;
use std::path::Path;

use rmd_bus::wire;
use rmd_protocol::{EncoderWidth, IqControl, MotorId};
use serde::{Deserialize, Serialize};

use crate::schedule::{OverrunPolicy, Period};

/// Most buses one loop drives.
pub const MAX_BUSES: usize = 8;
/// Most motors one bus carries: one 0x280 frame addresses ids 1..=4.
pub const MAX_MOTORS_PER_BUS: usize = 4;
/// Most motors one loop drives.
pub const MAX_MOTORS: usize = MAX_BUSES * MAX_MOTORS_PER_BUS;
/// Largest torque current a 0x280 command can carry (iqControl 2000 = 32 A).
pub const MAX_COMMAND_AMPS: f64 = 32.0;

/// A robot description that could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read robot description {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not valid TOML, or a key is unknown or of the wrong type.
    #[error("robot description: {0}")]
    Parse(String),
    /// A value is out of range or inconsistent.
    #[error("robot description: `{key}` {problem}")]
    Invalid {
        /// The key, as a path (e.g. `bus[0].motor[2].id`).
        key: String,
        /// What is wrong, and what is allowed.
        problem: String,
    },
}

fn invalid(key: impl Into<String>, problem: impl Into<String>) -> ConfigError {
    ConfigError::Invalid {
        key: key.into(),
        problem: problem.into(),
    }
}

/// When the loop takes a reply as this tick's feedback.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReplyMode {
    /// Replies to this tick's 0x280 frame must arrive before the reply deadline of the same tick.
    #[default]
    SameTick,
    /// For motors whose turnaround exceeds the reply window: the reply to the previous tick's
    /// frame is accepted as feedback (age 1 tick, reported to the controller) and is not missing.
    Pipelined,
}

/// Loop settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoopConfig {
    /// Tick rate in Hz.
    pub rate_hz: f64,
    /// CPU to pin the loop thread to.
    pub cpu: Option<usize>,
    /// `SCHED_FIFO` priority (1..=99); none runs under the normal scheduler.
    pub fifo_priority: Option<u8>,
    /// Lock the process's memory (`mlockall`) when the loop starts.
    pub lock_memory: bool,
    /// Busy-wait this long before each deadline for a precise wake (0: sleep only).
    pub spin_margin_us: u64,
    /// Replies are collected until this long after the tick's scheduled start; the rest of the
    /// period is left for the controller. Default: the period minus 10% (at least 50 us).
    pub reply_deadline_us: Option<u64>,
    /// Same-tick or pipelined replies.
    pub reply_mode: ReplyMode,
    /// What to do when a tick overruns the next tick's start.
    pub overrun: OverrunPolicy,
    /// Consecutive ticks without fresh feedback from one motor that make a fault.
    pub missing_reply_fault_after: u32,
    /// Start-up probe exchanges (zero torque, each waiting up to max(4 periods, 20 ms)) allowed
    /// for every motor to answer once before the loop gives up.
    pub startup_probes: u32,
    /// Capacity of the telemetry queue, in ticks.
    pub telemetry_capacity: usize,
    /// Accept a period shorter than the worst-case exchange on a bus (benchmarks only: the loop
    /// then relies on frames being shorter than the worst case).
    pub allow_over_budget: bool,
}

impl Default for LoopConfig {
    fn default() -> Self {
        Self {
            rate_hz: 1000.0,
            cpu: None,
            fifo_priority: None,
            lock_memory: false,
            spin_margin_us: 0,
            reply_deadline_us: None,
            reply_mode: ReplyMode::SameTick,
            overrun: OverrunPolicy::Skip,
            missing_reply_fault_after: 20,
            startup_probes: 5,
            telemetry_capacity: 4096,
            allow_over_budget: false,
        }
    }
}

/// Which way a joint turns relative to its motor.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Direction {
    /// Joint angle grows with the motor angle.
    #[default]
    Normal,
    /// Joint angle grows when the motor angle shrinks.
    Reversed,
}

impl Direction {
    /// +1.0 or -1.0.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Normal => 1.0,
            Direction::Reversed => -1.0,
        }
    }
}

/// One motor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorConfig {
    /// Motor id (1..=4: one 0x280 frame drives ids 1..4).
    pub id: u8,
    /// A name for reports (e.g. "knee").
    #[serde(default)]
    pub name: Option<String>,
    /// Encoder resolution in bits (12..=18, default 14).
    #[serde(default = "default_encoder_bits")]
    pub encoder_bits: u8,
    /// Motor turns per joint turn (e.g. 6.0 for a 1:6 gearbox).
    #[serde(default = "one")]
    pub gear_ratio: f64,
    /// Joint direction relative to the motor.
    #[serde(default)]
    pub direction: Direction,
    /// Joint angle (degrees) subtracted after scaling: joint = dir * motor / gear - offset.
    #[serde(default)]
    pub zero_offset_deg: f64,
    /// Torque current limit in amperes applied to every command (0 < limit <= 32). The 0x280
    /// frame bypasses the motor's own "Max Torque Current" setting (spec, 0xA1 memo 1), so this
    /// is the only limit on the torque the loop commands.
    #[serde(default = "default_current_limit")]
    pub current_limit_amps: f64,
    /// Joint-side torque per ampere of torque current (N*m/A), for commands and feedback in N*m.
    #[serde(default)]
    pub torque_constant_nm_per_amp: Option<f64>,
    /// A reported temperature at or above this is a fault (degrees Celsius).
    #[serde(default)]
    pub temperature_limit_celsius: Option<f64>,
}

const FALLBACK_ID: MotorId = match MotorId::new(1) {
    Ok(id) => id,
    Err(_) => panic!("1 is a valid motor id"),
};

fn default_encoder_bits() -> u8 {
    14
}
fn one() -> f64 {
    1.0
}
fn default_current_limit() -> f64 {
    5.0
}

impl MotorConfig {
    /// A motor with default settings (14-bit encoder, no gearbox, 5 A limit).
    pub fn new(id: u8) -> Self {
        Self {
            id,
            name: None,
            encoder_bits: default_encoder_bits(),
            gear_ratio: 1.0,
            direction: Direction::Normal,
            zero_offset_deg: 0.0,
            current_limit_amps: default_current_limit(),
            torque_constant_nm_per_amp: None,
            temperature_limit_celsius: None,
        }
    }

    /// Sets the name.
    pub fn name(mut self, name: &str) -> Self {
        self.name = Some(name.to_string());
        self
    }
    /// Sets the encoder resolution.
    pub fn encoder_bits(mut self, bits: u8) -> Self {
        self.encoder_bits = bits;
        self
    }
    /// Sets the gear ratio.
    pub fn gear_ratio(mut self, ratio: f64) -> Self {
        self.gear_ratio = ratio;
        self
    }
    /// Sets the direction.
    pub fn direction(mut self, direction: Direction) -> Self {
        self.direction = direction;
        self
    }
    /// Sets the zero offset (joint degrees).
    pub fn zero_offset_deg(mut self, deg: f64) -> Self {
        self.zero_offset_deg = deg;
        self
    }
    /// Sets the current limit (amperes).
    pub fn current_limit(mut self, amps: f64) -> Self {
        self.current_limit_amps = amps;
        self
    }
    /// Sets the joint-side torque constant (N*m/A).
    pub fn torque_constant(mut self, nm_per_amp: f64) -> Self {
        self.torque_constant_nm_per_amp = Some(nm_per_amp);
        self
    }
    /// Sets the temperature fault limit.
    pub fn temperature_limit(mut self, celsius: f64) -> Self {
        self.temperature_limit_celsius = Some(celsius);
        self
    }

    /// The motor id (valid once [`RobotConfig::validate`] passed; an invalid id maps to 1).
    pub fn motor_id(&self) -> MotorId {
        MotorId::new(self.id).unwrap_or(FALLBACK_ID)
    }

    /// The encoder width (valid once [`RobotConfig::validate`] passed; an invalid width maps to
    /// the default 14 bits).
    pub fn encoder_width(&self) -> EncoderWidth {
        EncoderWidth::new(self.encoder_bits).unwrap_or_default()
    }

    fn validate(&self, key: &str) -> Result<(), ConfigError> {
        if !(1..=MAX_MOTORS_PER_BUS as u8).contains(&self.id) {
            return Err(invalid(
                format!("{key}.id"),
                format!(
                    "is {}, must be 1..=4 (one 0x280 frame drives motor ids 1 to 4; put more motors on another bus)",
                    self.id
                ),
            ));
        }
        if EncoderWidth::new(self.encoder_bits).is_err() {
            return Err(invalid(
                format!("{key}.encoder_bits"),
                format!("is {}, must be 12..=18", self.encoder_bits),
            ));
        }
        if !(self.gear_ratio.is_finite() && self.gear_ratio > 0.0) {
            return Err(invalid(
                format!("{key}.gear_ratio"),
                format!("is {}, must be a positive number", self.gear_ratio),
            ));
        }
        if !self.zero_offset_deg.is_finite() {
            return Err(invalid(format!("{key}.zero_offset_deg"), "must be finite"));
        }
        if !(self.current_limit_amps.is_finite()
            && self.current_limit_amps > 0.0
            && self.current_limit_amps <= MAX_COMMAND_AMPS)
        {
            return Err(invalid(
                format!("{key}.current_limit_amps"),
                format!(
                    "is {}, must be in (0, {MAX_COMMAND_AMPS}] A",
                    self.current_limit_amps
                ),
            ));
        }
        if let Some(kt) = self.torque_constant_nm_per_amp
            && !(kt.is_finite() && kt > 0.0)
        {
            return Err(invalid(
                format!("{key}.torque_constant_nm_per_amp"),
                format!("is {kt}, must be a positive number"),
            ));
        }
        if let Some(t) = self.temperature_limit_celsius
            && !(t.is_finite() && (-40.0..=127.0).contains(&t))
        {
            return Err(invalid(
                format!("{key}.temperature_limit_celsius"),
                format!("is {t}, must be in -40..=127 degC"),
            ));
        }
        Ok(())
    }

    /// The current limit as a raw command value.
    pub fn current_limit_raw(&self) -> i16 {
        IqControl::from_amps_saturating(self.current_limit_amps).raw()
    }
}

/// One CAN bus and the motors on it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusConfig {
    /// A name for reports.
    #[serde(default)]
    pub name: Option<String>,
    /// SocketCAN interface (e.g. "can0"); "sim" for the simulator.
    pub interface: String,
    /// Bit rate in bit/s.
    #[serde(default = "default_bitrate")]
    pub bitrate: u32,
    /// Expected motor turnaround (request received to reply queued), microseconds, for the
    /// exchange budget.
    #[serde(default = "default_turnaround")]
    pub turnaround_us: u64,
    /// The motors.
    #[serde(default, rename = "motor")]
    pub motors: Vec<MotorConfig>,
}

fn default_bitrate() -> u32 {
    1_000_000
}
fn default_turnaround() -> u64 {
    200
}

impl BusConfig {
    /// A bus on `interface` at 1 Mbit/s with no motors yet.
    pub fn new(interface: &str) -> Self {
        Self {
            name: None,
            interface: interface.to_string(),
            bitrate: default_bitrate(),
            turnaround_us: default_turnaround(),
            motors: Vec::new(),
        }
    }
    /// Adds a motor.
    pub fn with_motor(mut self, motor: MotorConfig) -> Self {
        self.motors.push(motor);
        self
    }
    /// Sets the bit rate.
    pub fn bitrate(mut self, bitrate: u32) -> Self {
        self.bitrate = bitrate;
        self
    }
    /// Sets the expected turnaround.
    pub fn turnaround(mut self, turnaround: Duration) -> Self {
        self.turnaround_us = turnaround.as_micros() as u64;
        self
    }

    /// Worst-case duration of one exchange on this bus.
    pub fn exchange_budget(&self) -> Duration {
        wire::exchange_budget(
            self.motors.len() as u32,
            self.bitrate,
            Duration::from_micros(self.turnaround_us),
        )
    }
}

/// A whole robot: the loop settings and its buses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    /// Loop settings.
    #[serde(default, rename = "loop")]
    pub loop_config: LoopConfig,
    /// Buses, in order; motors are numbered bus by bus in this order.
    #[serde(default, rename = "bus")]
    pub buses: Vec<BusConfig>,
}

impl RobotConfig {
    /// An empty robot running at `rate_hz`.
    pub fn new(rate_hz: f64) -> Self {
        Self {
            loop_config: LoopConfig {
                rate_hz,
                ..LoopConfig::default()
            },
            buses: Vec::new(),
        }
    }

    /// Adds a bus.
    pub fn with_bus(mut self, bus: BusConfig) -> Self {
        self.buses.push(bus);
        self
    }

    /// Parses and validates a TOML robot description.
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let config: RobotConfig =
            toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        config.validate()?;
        Ok(config)
    }

    /// Reads, parses and validates a TOML robot description file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml(&text)
    }

    /// The description as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// Number of motors over all buses.
    pub fn motor_count(&self) -> usize {
        self.buses.iter().map(|b| b.motors.len()).sum()
    }

    /// The validated period.
    pub fn period(&self) -> Result<Period, ConfigError> {
        Period::from_hz(self.loop_config.rate_hz)
            .map_err(|e| invalid("loop.rate_hz", e.to_string()))
    }

    /// The reply deadline, measured from the tick's scheduled start.
    pub fn reply_deadline(&self) -> Result<Duration, ConfigError> {
        let period = self.period()?.get();
        Ok(match self.loop_config.reply_deadline_us {
            Some(us) => Duration::from_micros(us),
            None => period
                .saturating_sub((period / 10).max(Duration::from_micros(50)))
                .max(period / 2),
        })
    }

    /// Checks every value and the consistency of the whole; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let l = &self.loop_config;
        let period = self.period()?.get();
        if let Some(p) = l.fifo_priority
            && !(1..=99).contains(&p)
        {
            return Err(invalid(
                "loop.fifo_priority",
                format!("is {p}, must be 1..=99"),
            ));
        }
        let spin = Duration::from_micros(l.spin_margin_us);
        if spin >= period {
            return Err(invalid(
                "loop.spin_margin_us",
                format!(
                    "is {} us, must be shorter than the period ({} us)",
                    l.spin_margin_us,
                    period.as_micros()
                ),
            ));
        }
        let reply_deadline = self.reply_deadline()?;
        if reply_deadline.is_zero() || reply_deadline > period {
            return Err(invalid(
                "loop.reply_deadline_us",
                format!(
                    "is {} us, must be within the period (1..={} us)",
                    reply_deadline.as_micros(),
                    period.as_micros()
                ),
            ));
        }
        if l.missing_reply_fault_after == 0 {
            return Err(invalid(
                "loop.missing_reply_fault_after",
                "must be at least 1",
            ));
        }
        if l.startup_probes == 0 {
            return Err(invalid("loop.startup_probes", "must be at least 1"));
        }
        if l.telemetry_capacity == 0 {
            return Err(invalid("loop.telemetry_capacity", "must be at least 1"));
        }
        if let OverrunPolicy::Fault { after: 0 } = l.overrun {
            return Err(invalid("loop.overrun.after", "must be at least 1"));
        }
        if self.buses.len() > MAX_BUSES {
            return Err(invalid(
                "bus",
                format!(
                    "has {} buses, at most {MAX_BUSES} are supported",
                    self.buses.len()
                ),
            ));
        }
        for (b, bus) in self.buses.iter().enumerate() {
            let key = format!("bus[{b}]");
            if bus.interface.trim().is_empty() {
                return Err(invalid(format!("{key}.interface"), "must not be empty"));
            }
            if !(10_000..=1_000_000).contains(&bus.bitrate) {
                return Err(invalid(
                    format!("{key}.bitrate"),
                    format!(
                        "is {}, must be 10000..=1000000 bit/s (classic CAN)",
                        bus.bitrate
                    ),
                ));
            }
            if bus.motors.is_empty() {
                return Err(invalid(
                    format!("{key}.motor"),
                    "a bus needs at least one motor",
                ));
            }
            if bus.motors.len() > MAX_MOTORS_PER_BUS {
                return Err(invalid(
                    format!("{key}.motor"),
                    format!(
                        "has {} motors, one 0x280 frame drives at most 4 (ids 1..=4)",
                        bus.motors.len()
                    ),
                ));
            }
            for (m, motor) in bus.motors.iter().enumerate() {
                let mkey = format!("{key}.motor[{m}]");
                motor.validate(&mkey)?;
                if bus.motors[..m].iter().any(|o| o.id == motor.id) {
                    return Err(invalid(
                        format!("{mkey}.id"),
                        format!("motor id {} appears twice on {key}", motor.id),
                    ));
                }
            }
            // The bus must carry one exchange per tick (same tick: before the reply deadline).
            let budget = bus.exchange_budget();
            let window = match l.reply_mode {
                ReplyMode::SameTick => reply_deadline,
                ReplyMode::Pipelined => period,
            };
            if budget > window && !l.allow_over_budget {
                return Err(invalid(
                    key.clone(),
                    format!(
                        "cannot carry one exchange per tick: {} motors at {} bit/s with {} us \
                         turnaround need up to {} us (worst-case bit stuffing), but the {} is {} us. \
                         Lower loop.rate_hz, raise the bit rate, spread the motors over more \
                         buses, or use reply_mode = \"pipelined\"",
                        bus.motors.len(),
                        bus.bitrate,
                        bus.turnaround_us,
                        budget.as_micros(),
                        match l.reply_mode {
                            ReplyMode::SameTick => "reply deadline",
                            ReplyMode::Pipelined => "period",
                        },
                        window.as_micros()
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LEG: &str = r#"
        [loop]
        rate_hz = 500.0
        cpu = 1
        spin_margin_us = 20
        overrun = { policy = "fault", after = 5 }

        [[bus]]
        interface = "can0"

        [[bus.motor]]
        id = 1
        name = "hip"
        gear_ratio = 6.0
        direction = "reversed"
        current_limit_amps = 8.0
        torque_constant_nm_per_amp = 0.52

        [[bus.motor]]
        id = 2
    "#;

    fn expect_invalid(text: &str, key: &str) {
        match RobotConfig::from_toml(text) {
            Err(ConfigError::Invalid { key: k, problem }) => {
                assert_eq!(k, key, "{problem}")
            }
            other => panic!("expected an error on {key}, got {other:?}"),
        }
    }

    #[test]
    fn a_leg_description_parses() {
        let robot = RobotConfig::from_toml(LEG).unwrap();
        assert_eq!(robot.loop_config.rate_hz, 500.0);
        assert_eq!(robot.loop_config.overrun, OverrunPolicy::Fault { after: 5 });
        assert_eq!(robot.motor_count(), 2);
        let hip = &robot.buses[0].motors[0];
        assert_eq!(hip.direction, Direction::Reversed);
        assert_eq!(hip.encoder_bits, 14);
        assert_eq!(robot.buses[0].bitrate, 1_000_000);
        assert_eq!(robot.reply_deadline().unwrap(), Duration::from_micros(1800));
        // Round trip through TOML.
        assert_eq!(RobotConfig::from_toml(&robot.to_toml()).unwrap(), robot);
    }

    #[test]
    fn bad_values_name_their_key() {
        expect_invalid(&LEG.replace("id = 2", "id = 5"), "bus[0].motor[1].id");
        expect_invalid(&LEG.replace("id = 2", "id = 1"), "bus[0].motor[1].id");
        expect_invalid(
            &LEG.replace("gear_ratio = 6.0", "gear_ratio = -6.0"),
            "bus[0].motor[0].gear_ratio",
        );
        expect_invalid(
            &LEG.replace("current_limit_amps = 8.0", "current_limit_amps = 40.0"),
            "bus[0].motor[0].current_limit_amps",
        );
        expect_invalid(
            &LEG.replace("rate_hz = 500.0", "rate_hz = 0.0"),
            "loop.rate_hz",
        );
        expect_invalid(
            &LEG.replace("spin_margin_us = 20", "spin_margin_us = 5000"),
            "loop.spin_margin_us",
        );
        expect_invalid(&LEG.replace("after = 5", "after = 0"), "loop.overrun.after");
        expect_invalid(
            &LEG.replace(
                "[[bus.motor]]\n        id = 2",
                "[[bus.motor]]\n        id = 2\n        encoder_bits = 20",
            ),
            "bus[0].motor[1].encoder_bits",
        );
    }

    #[test]
    fn unknown_keys_and_wrong_types_are_parse_errors_naming_the_key() {
        let err = RobotConfig::from_toml(&LEG.replace("cpu = 1", "cpus = 1")).unwrap_err();
        assert!(
            matches!(&err, ConfigError::Parse(m) if m.contains("cpus")),
            "{err}"
        );
        let err = RobotConfig::from_toml(&LEG.replace("cpu = 1", "cpu = \"one\"")).unwrap_err();
        assert!(
            matches!(&err, ConfigError::Parse(m) if m.contains("cpu")),
            "{err}"
        );
    }

    #[test]
    fn a_period_the_bus_cannot_carry_is_refused() {
        // 4 motors at 1 Mbit/s need up to 875 us: 2 kHz (500 us period) cannot work.
        let mut bus = BusConfig::new("can0");
        for id in 1..=4 {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        let robot = RobotConfig::new(2000.0).with_bus(bus.clone());
        let err = robot.validate().unwrap_err();
        assert!(err.to_string().contains("875 us"), "{err}");
        // 1 kHz fits with the default 900 us reply deadline.
        RobotConfig::new(1000.0)
            .with_bus(bus.clone())
            .validate()
            .unwrap();
        // Pipelined mode only needs the exchange to fit in the period.
        let mut pipelined = RobotConfig::new(1100.0).with_bus(bus.clone());
        pipelined.loop_config.reply_mode = ReplyMode::Pipelined;
        pipelined.validate().unwrap();
        // A lower bit rate needs a lower rate.
        let slow = RobotConfig::new(1000.0).with_bus(bus.bitrate(500_000));
        assert!(slow.validate().is_err());
    }

    #[test]
    fn more_than_four_motors_on_a_bus_is_refused() {
        let mut bus = BusConfig::new("can0");
        for id in [1, 2, 3, 4, 4] {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        let err = RobotConfig::new(100.0)
            .with_bus(bus)
            .validate()
            .unwrap_err();
        assert!(matches!(err, ConfigError::Invalid { ref key, .. } if key == "bus[0].motor"));
    }
}
