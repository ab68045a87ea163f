//! A joint's limits as the description gives them (`position_min_deg`, `position_max_deg`,
//! `velocity_limit_dps` and their margins), checked and typed.
//!
//! The loop enforces them below every controller: past a limit it refuses torque that pushes
//! the joint further out (zero torque that way, counted per joint), and a joint further past a
//! limit than its margin is a fault that stops the run. The servo refuses setpoints and
//! trajectories outside them before anything moves.

use super::error::{RobotError, Shown, invalid};
use super::file::MotorConfig;

/// The largest joint angle a position limit may name, either way: ten turns of the joint.
pub const MAX_LIMIT_DEG: f64 = 3600.0;
/// The fastest velocity limit, deg/s (about 280 turns of the joint per second).
pub const MAX_VELOCITY_LIMIT_DPS: f64 = 100_000.0;
/// The largest position margin, degrees (one turn).
pub const MAX_LIMIT_MARGIN_DEG: f64 = 360.0;
/// The position margin unless the description gives one, degrees.
pub const DEFAULT_LIMIT_MARGIN_DEG: f64 = 5.0;

/// A joint's limits, joint side, in degrees and deg/s. A limit the description does not give
/// is infinite (the comparisons then never trip).
///
/// ```
/// use rmd_loop::robot::Robot;
/// let robot = Robot::from_toml(r#"
///     [[bus]]
///     interface = "sim"
///     [[bus.motor]]
///     id = 1
///     name = "knee"
///     position_min_deg = 5.0
///     position_max_deg = 165.0
///     velocity_limit_dps = 360.0
/// "#)?;
/// let limits = robot.joints()[0].limits;
/// assert_eq!(limits.position(), Some((5.0, 165.0)));
/// assert_eq!(limits.position_margin_deg, 5.0); // the default
/// assert_eq!(limits.velocity(), Some(360.0));
/// assert_eq!(limits.velocity_margin_dps, 180.0); // half the limit
/// # Ok::<(), rmd_loop::robot::RobotError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointLimits {
    /// Lowest angle, degrees (`-inf`: none).
    pub position_min_deg: f64,
    /// Highest angle, degrees (`inf`: none).
    pub position_max_deg: f64,
    /// How far past a position limit is a fault, degrees (> 0).
    pub position_margin_deg: f64,
    /// Fastest velocity either way, deg/s (`inf`: none).
    pub velocity_max_dps: f64,
    /// How far above the velocity limit is a fault, deg/s (> 0; `inf` without a limit).
    pub velocity_margin_dps: f64,
}

impl JointLimits {
    /// No limits.
    pub const NONE: Self = Self {
        position_min_deg: f64::NEG_INFINITY,
        position_max_deg: f64::INFINITY,
        position_margin_deg: DEFAULT_LIMIT_MARGIN_DEG,
        velocity_max_dps: f64::INFINITY,
        velocity_margin_dps: f64::INFINITY,
    };

    /// `(min, max)` degrees, when the description gives either (the other may be infinite).
    pub fn position(&self) -> Option<(f64, f64)> {
        (self.position_min_deg.is_finite() || self.position_max_deg.is_finite())
            .then_some((self.position_min_deg, self.position_max_deg))
    }

    /// The velocity limit, deg/s, when the description gives one.
    pub fn velocity(&self) -> Option<f64> {
        self.velocity_max_dps
            .is_finite()
            .then_some(self.velocity_max_dps)
    }

    /// Whether the description gives any limit.
    pub fn any(&self) -> bool {
        self.position().is_some() || self.velocity().is_some()
    }

    /// Whether `angle_deg` lies within the position limits.
    pub fn allows_position(&self, angle_deg: f64) -> bool {
        (self.position_min_deg..=self.position_max_deg).contains(&angle_deg)
    }
}

/// The limits of the motor at `key`, checked.
pub(super) fn joint_limits(m: &MotorConfig, key: &str) -> Result<JointLimits, RobotError> {
    let angle = |name: &str, v: Option<f64>, none: f64| match v {
        None => Ok(none),
        Some(v) if (-MAX_LIMIT_DEG..=MAX_LIMIT_DEG).contains(&v) => Ok(v),
        Some(v) => Err(invalid(
            format!("{key}.{name}"),
            format!(
                "is {}, must be a joint angle within +-{MAX_LIMIT_DEG} degrees",
                Shown(v)
            ),
        )),
    };
    let min = angle("position_min_deg", m.position_min_deg, f64::NEG_INFINITY)?;
    let max = angle("position_max_deg", m.position_max_deg, f64::INFINITY)?;
    if min >= max {
        return Err(invalid(
            format!("{key}.position_max_deg"),
            format!("is {max}, must be above position_min_deg ({min})"),
        ));
    }
    let positive = |name: &str, v: f64, most: f64, unit: &str| {
        if v > 0.0 && v <= most {
            Ok(v)
        } else {
            Err(invalid(
                format!("{key}.{name}"),
                format!("is {}, must be above 0 and at most {most} {unit}", Shown(v)),
            ))
        }
    };
    let has_position = m.position_min_deg.is_some() || m.position_max_deg.is_some();
    let position_margin_deg = match m.limit_margin_deg {
        Some(_) if !has_position => {
            return Err(invalid(
                format!("{key}.limit_margin_deg"),
                "is given but the joint has no position limit: set position_min_deg and/or \
                 position_max_deg",
            ));
        }
        Some(v) => positive("limit_margin_deg", v, MAX_LIMIT_MARGIN_DEG, "degrees")?,
        None => DEFAULT_LIMIT_MARGIN_DEG,
    };
    let (velocity_max_dps, velocity_margin_dps) =
        match (m.velocity_limit_dps, m.velocity_margin_dps) {
            (None, None) => (f64::INFINITY, f64::INFINITY),
            (None, Some(_)) => {
                return Err(invalid(
                    format!("{key}.velocity_margin_dps"),
                    "is given but the joint has no velocity_limit_dps",
                ));
            }
            (Some(limit), margin) => {
                let limit = positive("velocity_limit_dps", limit, MAX_VELOCITY_LIMIT_DPS, "deg/s")?;
                let margin = match margin {
                    Some(v) => positive("velocity_margin_dps", v, MAX_VELOCITY_LIMIT_DPS, "deg/s")?,
                    None => limit / 2.0,
                };
                (limit, margin)
            }
        };
    Ok(JointLimits {
        position_min_deg: min,
        position_max_deg: max,
        position_margin_deg,
        velocity_max_dps,
        velocity_margin_dps,
    })
}
