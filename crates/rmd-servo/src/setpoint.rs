//! What a caller asks of one joint, and the check against its limits (on the caller's thread).

use rmd_loop::JointId;

use crate::config::{EFFORT_KEY, JointServo};
use crate::error::ServoError;

/// A setpoint for one joint, in joint units (rad, rad/s, N·m).
///
/// The servo's law for each (τ: the torque it commands, clamped to the joint's
/// `max_effort_nm`; p, v: measured position and velocity):
///
/// - `Position`: τ = kp·(position − p) + kd·(velocity_ff − v) + effort_ff;
/// - `Velocity`: a position reference r advances by velocity·dt every tick (kept within the
///   position limits and within max_effort/kp of p), τ = kp·(r − p) + kd·(velocity − v) +
///   effort_ff;
/// - `Effort`: τ = effort.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Setpoint {
    /// Go to a position, with velocity and effort feed-forward.
    Position {
        /// Target position, rad.
        position_rad: f64,
        /// Velocity feed-forward, rad/s (the D term's reference).
        velocity_ff_rad_s: f64,
        /// Effort feed-forward, N·m (added to the PD output).
        effort_ff_nm: f64,
    },
    /// Turn at a velocity, with effort feed-forward.
    Velocity {
        /// Target velocity, rad/s.
        velocity_rad_s: f64,
        /// Effort feed-forward, N·m.
        effort_ff_nm: f64,
    },
    /// Apply a torque.
    Effort {
        /// Torque, N·m.
        effort_nm: f64,
    },
}

impl Setpoint {
    /// A position without feed-forward.
    pub const fn position(position_rad: f64) -> Self {
        Setpoint::Position {
            position_rad,
            velocity_ff_rad_s: 0.0,
            effort_ff_nm: 0.0,
        }
    }

    /// A velocity without feed-forward.
    pub const fn velocity(velocity_rad_s: f64) -> Self {
        Setpoint::Velocity {
            velocity_rad_s,
            effort_ff_nm: 0.0,
        }
    }

    /// A torque.
    pub const fn effort(effort_nm: f64) -> Self {
        Setpoint::Effort { effort_nm }
    }

    /// Checks every value against `joint`'s limits: finite, position within the position
    /// limits, velocities within the velocity limit, efforts within the effort limit.
    pub(crate) fn check(&self, joint: &JointServo) -> Result<(), ServoError> {
        let l = &joint.limits;
        let v = l.max_velocity_rad_s;
        let e = l.max_effort_nm;
        let position = (l.position_min_rad, l.position_max_rad, l.position_keys());
        let velocity_key = l.velocity_from.velocity_key();
        let velocity = (-v, v, (velocity_key, velocity_key));
        let effort = (-e, e, (EFFORT_KEY, EFFORT_KEY));
        type Keys = (&'static str, &'static str);
        let fields: &[(&'static str, f64, (f64, f64, Keys))] = match *self {
            Setpoint::Position {
                position_rad,
                velocity_ff_rad_s,
                effort_ff_nm,
            } => &[
                ("position_rad", position_rad, position),
                ("velocity_ff_rad_s", velocity_ff_rad_s, velocity),
                ("effort_ff_nm", effort_ff_nm, effort),
            ],
            Setpoint::Velocity {
                velocity_rad_s,
                effort_ff_nm,
            } => &[
                ("velocity_rad_s", velocity_rad_s, velocity),
                ("effort_ff_nm", effort_ff_nm, effort),
            ],
            Setpoint::Effort { effort_nm } => &[("effort_nm", effort_nm, effort)],
        };
        for &(field, value, (min, max, keys)) in fields {
            check_value(&joint.name, field, value, min, max, keys)?;
        }
        Ok(())
    }
}

/// `value` must be finite and within `[min, max]`; `keys` name the lower and the upper limit
/// (with where each comes from).
pub(crate) fn check_value(
    joint: &str,
    field: &'static str,
    value: f64,
    min: f64,
    max: f64,
    keys: (&'static str, &'static str),
) -> Result<(), ServoError> {
    if !value.is_finite() {
        return Err(ServoError::NotFinite {
            joint: joint.to_string(),
            field,
            value,
        });
    }
    if !(value >= min && value <= max) {
        return Err(ServoError::OutOfLimit {
            joint: joint.to_string(),
            field,
            value,
            min,
            max,
            key: if value < min { keys.0 } else { keys.1 },
        });
    }
    Ok(())
}

/// A joint by id or by name (names are resolved on the caller's thread).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum JointRef<'a> {
    /// A joint id of the servo's robot.
    Id(JointId),
    /// A joint name of the servo's robot.
    Name(&'a str),
}

impl From<JointId> for JointRef<'_> {
    fn from(id: JointId) -> Self {
        JointRef::Id(id)
    }
}

impl<'a> From<&'a str> for JointRef<'a> {
    fn from(name: &'a str) -> Self {
        JointRef::Name(name)
    }
}

impl<'a> From<&'a String> for JointRef<'a> {
    fn from(name: &'a String) -> Self {
        JointRef::Name(name)
    }
}
