//! One joint and its motor (`[[bus.motor]]`), checked: the motor's id, dialect and model,
//! its encoder, gearbox, zero, current limit, torque constant, temperature limit, joint
//! limits, brake and watchdog.

use core::time::Duration;

use rmd_protocol::{
    CurrentScale, Dialect, EncoderWidth, MODELS, MotorId, MotorModel, WatchdogTimeout, find_model,
};

use super::error::{RobotError, Shown, invalid};
use super::file::{BusConfig, Direction, MotorConfig};
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
    pub direction: Direction,
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
