//! One joint and its motor (`[[bus.motor]]`), checked: the motor's id, dialect and model,
//! its encoder, gearbox, zero, current limit, torque constant, temperature limit, joint
//! limits, brake and watchdog.

use core::time::Duration;

use rmd_protocol::{
    CurrentScale, Dialect, EncoderWidth, MODELS, MotorId, MotorModel, WatchdogTimeout, find_model,
};

use super::error::{RobotError, Shown, invalid};
use super::file::{BusConfig, MotorConfig, Mounting};
use super::limits::{self, JointLimits};
use super::settings::LoopSettings;

/// The highest motor id of a `per-motor` bus (the protocol's ids are 1..=32).
pub const MAX_PER_MOTOR_ID: u8 = 32;
/// Largest torque current a v1.61 0x280 command can carry (iqControl 2000 = 32 A; other
/// dialects: their own range).
pub const MAX_COMMAND_AMPS: f64 = 32.0;

/// The physically meaningful range of `gear_ratio` (motor turns per joint turn): from a 1:100
/// step-up to a 1000:1 reduction.
pub const GEAR_RATIO_RANGE: core::ops::RangeInclusive<f64> = 0.01..=1000.0;
/// The largest `zero_offset_deg`, either way: ten turns of the joint.
pub const MAX_ZERO_OFFSET_DEG: f64 = 3600.0;
/// The physically meaningful range of `torque_constant_nm_per_amp` (joint side, N*m/A).
pub const TORQUE_CONSTANT_RANGE: core::ops::RangeInclusive<f64> = 1e-4..=1000.0;

/// A torque current limit: amperes, and the raw command it allows in the joint's dialect.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CurrentLimit {
    amps: f64,
    raw: i16,
}

impl CurrentLimit {
    /// The limit in amperes (above 0, at most the dialect's command range).
    pub fn amps(self) -> f64 {
        self.amps
    }

    /// The largest raw command magnitude it allows (rounded towards zero).
    pub fn raw(self) -> i16 {
        self.raw
    }
}

/// One joint and its motor, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct JointSpec {
    /// The joint's name (unique in the robot).
    pub name: String,
    /// The bus it is on (index in description order).
    pub bus: usize,
    /// Its motor's id (1..=4 on a `multi-torque` bus, 1..=32 on a `per-motor` one).
    pub motor: MotorId,
    /// The protocol dialect its firmware speaks (the current scales of its commands and replies).
    pub dialect: Dialect,
    /// Its model, when the description names one.
    pub model: Option<&'static str>,
    /// The motor's encoder width.
    pub encoder: EncoderWidth,
    /// Motor turns per joint turn (positive).
    pub gear_ratio: f64,
    /// Joint direction relative to the motor.
    pub direction: Mounting,
    /// Joint angle subtracted after scaling, degrees.
    pub zero_offset_deg: f64,
    /// The limit applied to every torque command.
    pub current_limit: CurrentLimit,
    /// Joint-side torque per ampere (N*m/A), if known.
    pub torque_constant_nm_per_amp: Option<f64>,
    /// A reported temperature at or above this is a fault.
    pub temperature_limit_celsius: Option<f64>,
    /// Its position and velocity limits, enforced by the loop below every controller.
    pub limits: JointLimits,
    /// A holding brake is fitted (MyActuator V3): locked by the safe stop.
    pub brake: bool,
    /// The communication watchdog the description says is in the motor's ROM (MyActuator V3;
    /// `None`: not described).
    pub watchdog: Option<WatchdogTimeout>,
}

impl JointSpec {
    /// The motor's slot in its bus's 0x280 frame (id - 1).
    pub fn slot(&self) -> usize {
        usize::from(self.motor.get() - 1)
    }

    /// The scale of its torque commands (0x280 slots, 0xA1).
    pub fn command_scale(&self) -> CurrentScale {
        self.dialect.iq_control_scale()
    }

    /// The scale of the torque current in its replies.
    pub fn reply_scale(&self) -> CurrentScale {
        self.dialect.iq_scale()
    }
}

/// The model named at `key`, if any.
fn model_of(m: &MotorConfig, key: &str) -> Result<Option<&'static MotorModel>, RobotError> {
    let Some(name) = &m.model else {
        return Ok(None);
    };
    find_model(name).map(Some).map_err(|_| {
        invalid(
            format!("{key}.model"),
            format!(
                "is `{name}`, which rmd-rt does not know (known models: {}); describe the motor \
                 with its own keys instead",
                MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// The motor's dialect: its own `protocol`, the bus's, the model's, or v1.61.
fn dialect_of(
    bus: &BusConfig,
    m: &MotorConfig,
    model: Option<&MotorModel>,
    key: &str,
) -> Result<Dialect, RobotError> {
    let (protocol, protocol_key) = match (&m.protocol, &bus.protocol) {
        (Some(p), _) => (Some(p.as_str()), format!("{key}.protocol")),
        (None, Some(p)) => (Some(p.as_str()), format!("{key}.protocol (from its bus)")),
        (None, None) => (None, format!("{key}.protocol")),
    };
    let series = m.lk_series.as_deref().or(bus.lk_series.as_deref()).or(model
        .and_then(|md| md.dialect.lk_series())
        .map(|s| s.name()));
    // A MyActuator V3 motor is driven per motor: its bus's exchange is checked with the bus.
    let model_dialect = model.map(|md| md.dialect);
    let dialect = match protocol {
        Some(p) => Dialect::from_names(p, series).map_err(|e| {
            invalid(
                protocol_key.clone(),
                format!(
                    "is `{p}`: {e} (\"v1.61\", \"myactuator-v3\", or \"lk-v2.3x\" with lk_series = \
                     \"mf\" or \"mg\")"
                ),
            )
        })?,
        None => model_dialect.unwrap_or_default(),
    };
    if let (Some(md), Some(model_dialect)) = (model, model_dialect)
        && model_dialect.family() != dialect.family()
    {
        return Err(invalid(
            protocol_key,
            format!(
                "is {}, but model `{}` speaks {}",
                dialect.name(),
                md.name,
                model_dialect.name()
            ),
        ));
    }
    Ok(dialect)
}

/// Motor entry `m` of bus `b` (at `key`), checked alone: each key's rule where the key is
/// read; the rules across motors, buses and the loop are the caller's.
pub(super) fn joint_spec(
    b: usize,
    bus: &BusConfig,
    m: &MotorConfig,
    key: &str,
) -> Result<JointSpec, RobotError> {
    let model = model_of(m, key)?;
    let dialect = dialect_of(bus, m, model, key)?;
    // 1..=4 on a multi-torque bus: checked with the bus (`check_bus_layout`).
    let motor = MotorId::new(m.id).ok().ok_or_else(|| {
        invalid(
            format!("{key}.id"),
            format!("is {}, must be 1..={MAX_PER_MOTOR_ID}", m.id),
        )
    })?;
    if m.brake && dialect.v3_firmware().is_none() {
        return Err(invalid(
            format!("{key}.brake"),
            format!(
                "is true, but the motor speaks {}: only MyActuator V3 motors have brake commands",
                dialect.name()
            ),
        ));
    }
    if let Some(millis) = m.watchdog_ms {
        check_watchdog(millis, dialect, &format!("{key}.watchdog_ms"))?;
    }
    let encoder = match (m.encoder_bits, model.and_then(|md| md.encoder_bits)) {
        (Some(bits), _) => EncoderWidth::new(bits).map_err(|_| {
            invalid(
                format!("{key}.encoder_bits"),
                format!(
                    "is {bits}, must be {}..={}",
                    EncoderWidth::MIN_BITS,
                    EncoderWidth::MAX_BITS
                ),
            )
        })?,
        (None, Some(from_model)) => from_model.value,
        (None, None) => EncoderWidth::DEFAULT,
    };
    let gear_ratio = m
        .gear_ratio
        .or(model.and_then(|md| md.gear_ratio).map(|g| g.value))
        .unwrap_or(1.0);
    if !GEAR_RATIO_RANGE.contains(&gear_ratio) {
        return Err(invalid(
            format!("{key}.gear_ratio"),
            format!(
                "is {}, must be {}..={} (motor turns per joint turn: 9 for a 1:9 \
                 gearbox)",
                Shown(gear_ratio),
                GEAR_RATIO_RANGE.start(),
                GEAR_RATIO_RANGE.end()
            ),
        ));
    }
    let torque_constant = m.torque_constant_nm_per_amp.or(model
        .and_then(|md| md.torque_constant_nm_per_a)
        .map(|kt| kt.value));
    if !(-MAX_ZERO_OFFSET_DEG..=MAX_ZERO_OFFSET_DEG).contains(&m.zero_offset_deg) {
        return Err(invalid(
            format!("{key}.zero_offset_deg"),
            format!(
                "is {}, must be within +-{MAX_ZERO_OFFSET_DEG} degrees of joint (ten turns)",
                Shown(m.zero_offset_deg)
            ),
        ));
    }
    let amps = m.current_limit_amps;
    let scale = dialect.iq_control_scale();
    let max_amps = scale.max_amps();
    // At least one step of the command's scale: a smaller limit would allow no torque at all.
    let min_amps = scale.amps_per_lsb();
    if !(amps.is_finite() && amps >= min_amps && amps <= max_amps) {
        return Err(invalid(
            format!("{key}.current_limit_amps"),
            format!(
                "is {}, must be in [{min_amps}, {max_amps}] A (one step to the whole {} \
                 command range)",
                Shown(amps),
                dialect
            ),
        ));
    }
    if let Some(kt) = torque_constant
        && !TORQUE_CONSTANT_RANGE.contains(&kt)
    {
        return Err(invalid(
            format!("{key}.torque_constant_nm_per_amp"),
            format!(
                "is {}, must be {}..={} N*m/A (at the joint, after the gearbox)",
                Shown(kt),
                TORQUE_CONSTANT_RANGE.start(),
                TORQUE_CONSTANT_RANGE.end()
            ),
        ));
    }
    if let Some(t) = m.temperature_limit_celsius
        && !(t.is_finite() && (-40.0..=127.0).contains(&t))
    {
        return Err(invalid(
            format!("{key}.temperature_limit_celsius"),
            format!("is {}, must be in -40..=127 degC", Shown(t)),
        ));
    }
    let name = match &m.name {
        Some(name) if name.trim().is_empty() => {
            return Err(invalid(format!("{key}.name"), "must not be empty"));
        }
        Some(name) => name.clone(),
        None => format!("bus{b}_motor{}", m.id),
    };
    Ok(JointSpec {
        name,
        bus: b,
        motor,
        dialect,
        model: model.map(|md| md.name),
        encoder,
        gear_ratio,
        direction: m.direction,
        zero_offset_deg: m.zero_offset_deg,
        current_limit: CurrentLimit {
            amps,
            // Rounded towards zero: a clamped command never exceeds the described limit.
            raw: (amps / scale.amps_per_lsb())
                .floor()
                .min(f64::from(scale.max_raw())) as i16,
        },
        torque_constant_nm_per_amp: torque_constant,
        temperature_limit_celsius: m.temperature_limit_celsius,
        limits: limits::joint_limits(m, key)?,
        brake: m.brake,
        watchdog: m.watchdog_ms.map(WatchdogTimeout::from_millis),
    })
}

/// The shortest communication watchdog accepted: 5 ms proved too short on real motors (a
/// normal pause between two frames tripped it); 20 to 100 ms is usual.
pub const MIN_WATCHDOG_MS: u32 = 10;

/// A described communication watchdog: only MyActuator V3 motors have one, and a non-zero one
/// is at least [`MIN_WATCHDOG_MS`].
fn check_watchdog(millis: u32, dialect: Dialect, key: &str) -> Result<(), RobotError> {
    if dialect.v3_firmware().is_none() {
        return Err(invalid(
            key,
            format!(
                "is set, but the motor speaks {}: only MyActuator V3 motors have a communication \
                 watchdog (0xB3); leave the key out",
                dialect.name()
            ),
        ));
    }
    if millis != 0 && millis < MIN_WATCHDOG_MS {
        return Err(invalid(
            key,
            format!(
                "is {millis}, must be 0 (off) or at least {MIN_WATCHDOG_MS} ms: shorter ones trip \
                 on a normal pause between two frames (20 to 100 ms is usual)"
            ),
        ));
    }
    Ok(())
}

/// Periods of the loop a described watchdog must span at least: the loop sends each motor one
/// frame a period, and a late tick must not trip it.
const WATCHDOG_MIN_PERIODS: u32 = 3;

/// A described non-zero watchdog spans at least [`WATCHDOG_MIN_PERIODS`] of the loop's periods.
pub(super) fn check_watchdog_period(
    joint: &JointSpec,
    settings: &LoopSettings,
    key: &str,
) -> Result<(), RobotError> {
    let Some(watchdog) = joint.watchdog.filter(|w| !w.is_off()) else {
        return Ok(());
    };
    let shortest = settings.period.get() * WATCHDOG_MIN_PERIODS;
    if Duration::from_millis(u64::from(watchdog.millis())) < shortest {
        return Err(invalid(
            format!("{key}.watchdog_ms"),
            format!(
                "is {}, shorter than {WATCHDOG_MIN_PERIODS} of the loop's periods ({} ms at {} Hz): \
                 the motor would turn itself off whenever a tick came late; raise it or the rate",
                watchdog.millis(),
                shortest.as_secs_f64() * 1000.0,
                settings.period.hz()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::robot::test_fixtures::{LEG, expect_invalid, v3_bus};
    use crate::robot::{BusConfig, MotorConfig, Robot, RobotConfig, RobotError};

    #[test]
    fn bad_motor_values_name_their_key() {
        expect_invalid(&LEG.replace("id = 2", "id = 33"), "bus[0].motor[1].id");
        expect_invalid(&LEG.replace("id = 2", "id = 0"), "bus[0].motor[1].id");
        expect_invalid(
            &LEG.replace("gear_ratio = 6.0", "gear_ratio = -6.0"),
            "bus[0].motor[0].gear_ratio",
        );
        expect_invalid(
            &LEG.replace("current_limit_amps = 8.0", "current_limit_amps = 40.0"),
            "bus[0].motor[0].current_limit_amps",
        );
        expect_invalid(
            &LEG.replace(
                "[[bus.motor]]\n        id = 2",
                "[[bus.motor]]\n        id = 2\n        encoder_bits = 20",
            ),
            "bus[0].motor[1].encoder_bits",
        );
    }

    #[test]
    fn physically_absurd_motor_values_are_refused_naming_their_key() {
        let motor = "[[bus.motor]]\n        id = 2";
        let on_motor = |line: &str| LEG.replace(motor, &format!("{motor}\n        {line}"));
        for (line, key) in [
            ("gear_ratio = 1e308", "bus[0].motor[1].gear_ratio"),
            ("gear_ratio = 1e-308", "bus[0].motor[1].gear_ratio"),
            ("gear_ratio = nan", "bus[0].motor[1].gear_ratio"),
            ("gear_ratio = 0.0", "bus[0].motor[1].gear_ratio"),
            ("zero_offset_deg = 1e308", "bus[0].motor[1].zero_offset_deg"),
            (
                "zero_offset_deg = -3601.0",
                "bus[0].motor[1].zero_offset_deg",
            ),
            ("zero_offset_deg = inf", "bus[0].motor[1].zero_offset_deg"),
            (
                "torque_constant_nm_per_amp = 1e308",
                "bus[0].motor[1].torque_constant_nm_per_amp",
            ),
            (
                "torque_constant_nm_per_amp = 1e-308",
                "bus[0].motor[1].torque_constant_nm_per_amp",
            ),
            (
                "current_limit_amps = 1e-308",
                "bus[0].motor[1].current_limit_amps",
            ),
            (
                "temperature_limit_celsius = 1e308",
                "bus[0].motor[1].temperature_limit_celsius",
            ),
        ] {
            expect_invalid(&on_motor(line), key);
        }
        // The edges of the ranges are accepted: a 1:100 step-up, a 1000:1 reduction.
        for line in [
            "gear_ratio = 0.01",
            "gear_ratio = 1000.0",
            "zero_offset_deg = -3600.0",
        ] {
            Robot::from_toml(&on_motor(line)).unwrap();
        }
    }

    #[test]
    fn a_brake_is_described_on_v3_motors_only() {
        let braked = BusConfig::new("can0").with_motor(MotorConfig::new(1).brake(true));
        expect_invalid(
            &RobotConfig::new(100.0).with_bus(braked).to_toml(),
            "bus[0].motor[0].brake",
        );
        let braked = v3_bus(1);
        let mut braked = braked;
        braked.motors[0].brake = true;
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(braked)).unwrap();
        assert!(robot.joints()[0].brake);
    }

    #[test]
    fn every_width_from_12_to_18_bits_is_accepted() {
        for bits in 12..=18 {
            let text = LEG.replace(
                "[[bus.motor]]\n        id = 2",
                &format!("[[bus.motor]]\n        id = 2\n        encoder_bits = {bits}"),
            );
            let robot = Robot::from_toml(&text).unwrap();
            assert_eq!(robot.joints()[1].encoder.bits(), bits);
        }
    }

    #[test]
    fn a_watchdog_is_described_on_v3_motors_only_and_spans_several_periods() {
        let refused = |robot: RobotConfig, key: &str, words: &str| match Robot::try_from(robot) {
            Err(RobotError::Invalid {
                key: k, problem, ..
            }) => {
                assert_eq!(k, key, "{problem}");
                assert!(problem.contains(words), "{problem}");
            }
            other => panic!("expected an error on {key}, got {other:?}"),
        };
        // v1.61 has no watchdog.
        let v161 = BusConfig::new("can0").with_motor(MotorConfig::new(1).watchdog_ms(50));
        refused(
            RobotConfig::new(100.0).with_bus(v161),
            "bus[0].motor[0].watchdog_ms",
            "only MyActuator V3 motors have a communication watchdog",
        );
        // 5 ms proved too short on real motors.
        let mut short = v3_bus(1);
        short.motors[0].watchdog_ms = Some(5);
        refused(
            RobotConfig::new(1000.0).with_bus(short),
            "bus[0].motor[0].watchdog_ms",
            "at least 10 ms",
        );
        // At 50 Hz a tick is 20 ms: 50 ms is less than three of them.
        let mut slow = v3_bus(1);
        slow.motors[0].watchdog_ms = Some(50);
        refused(
            RobotConfig::new(50.0).with_bus(slow.clone()),
            "bus[0].motor[0].watchdog_ms",
            "shorter than 3 of the loop's periods (60 ms at 50 Hz)",
        );
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(slow)).unwrap();
        assert_eq!(robot.joints()[0].watchdog.map(|w| w.millis()), Some(50));
        // 0 describes a watchdog that is off, at any rate; no key, none described.
        let mut off = v3_bus(2);
        off.motors[0].watchdog_ms = Some(0);
        let robot = Robot::try_from(RobotConfig::new(1.0).with_bus(off)).unwrap();
        assert!(robot.joints()[0].watchdog.is_some_and(|w| w.is_off()));
        assert_eq!(robot.joints()[1].watchdog, None);
        // The key round-trips through TOML.
        let text = RobotConfig::new(100.0)
            .with_bus(
                BusConfig::new("can0")
                    .protocol("myactuator-v3")
                    .with_motor(MotorConfig::new(1).watchdog_ms(80)),
            )
            .to_toml();
        assert!(text.contains("watchdog_ms = 80"), "{text}");
        let robot = Robot::from_toml(&text).unwrap();
        assert_eq!(robot.joints()[0].watchdog.map(|w| w.millis()), Some(80));
    }
}
