//! The joint limits of the description, enforced below every controller.
//!
//! Each tick, before the controller runs, a joint further past a limit than its margin is a
//! fault ([`Fault::JointLimit`](crate::report::Fault::JointLimit)) that stops the run; after the
//! controller, a command that pushes a joint already past a limit further out is replaced by
//! zero torque (counted per joint as `limited`), while torque back towards the limits passes.
//! Position limits are refused in the direction of the limit, the velocity limit in the
//! direction of motion (braking passes).

use core::fmt;

use crate::feedback::JointSide;
use crate::robot::JointSpec;

/// Which limit a joint went past.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum LimitKind {
    /// Below `position_min_deg`.
    PositionMin,
    /// Above `position_max_deg`.
    PositionMax,
    /// Faster than `velocity_limit_dps`, either way.
    Velocity,
}

impl LimitKind {
    /// The description's key of the limit.
    pub fn key(self) -> &'static str {
        match self {
            LimitKind::PositionMin => "position_min_deg",
            LimitKind::PositionMax => "position_max_deg",
            LimitKind::Velocity => "velocity_limit_dps",
        }
    }

    /// Its unit.
    pub fn unit(self) -> &'static str {
        match self {
            LimitKind::PositionMin | LimitKind::PositionMax => "deg",
            LimitKind::Velocity => "deg/s",
        }
    }
}

impl fmt::Display for LimitKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.key())
    }
}

/// A joint further past a limit than its margin.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LimitBreach {
    /// Which limit.
    pub kind: LimitKind,
    /// Where the joint was: its angle (degrees) or velocity (deg/s).
    pub value: f64,
    /// The limit (degrees, or deg/s for the velocity limit: its magnitude).
    pub limit: f64,
    /// The margin it was further past the limit than.
    pub margin: f64,
}

impl fmt::Display for LimitBreach {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unit = self.kind.unit();
        let what = match self.kind {
            LimitKind::Velocity => "turns at",
            _ => "is at",
        };
        write!(
            f,
            "{what} {:.1} {unit}, past its {} of {} {unit} by more than its {} {unit} margin",
            self.value, self.kind, self.limit, self.margin
        )
    }
}

/// One joint's limits in the form the tick checks them: the joint sign of its motor and every
/// bound as a plain number (infinite where the description gives none).
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct LimitGuard {
    /// Joint sign per motor sign (`direction`).
    sign: f64,
    min_deg: f64,
    max_deg: f64,
    max_dps: f64,
    margin_deg: f64,
    margin_dps: f64,
}

impl LimitGuard {
    pub(crate) fn from_spec(spec: &JointSpec) -> Self {
        let l = spec.limits;
        Self {
            sign: spec.direction.sign(),
            min_deg: l.position_min_deg,
            max_deg: l.position_max_deg,
            max_dps: l.velocity_max_dps,
            margin_deg: l.position_margin_deg,
            margin_dps: l.velocity_margin_dps,
        }
    }

    /// Whether the motor-side current `motor_amps` pushes the joint, in `state`, further past
    /// a limit it is already past.
    #[inline]
    pub(crate) fn refuses(&self, state: &JointSide, motor_amps: f64) -> bool {
        let joint_amps = self.sign * motor_amps;
        let up = state.angle_deg > self.max_deg || state.velocity_dps > self.max_dps;
        let down = state.angle_deg < self.min_deg || state.velocity_dps < -self.max_dps;
        (joint_amps > 0.0 && up) || (joint_amps < 0.0 && down)
    }

    /// The limit the joint, in `state`, is further past than its margin, if any.
    #[inline]
    pub(crate) fn breach(&self, state: &JointSide) -> Option<LimitBreach> {
        let (angle, velocity) = (state.angle_deg, state.velocity_dps);
        let breach = |kind, value, limit, margin| {
            Some(LimitBreach {
                kind,
                value,
                limit,
                margin,
            })
        };
        if angle > self.max_deg + self.margin_deg {
            breach(LimitKind::PositionMax, angle, self.max_deg, self.margin_deg)
        } else if angle < self.min_deg - self.margin_deg {
            breach(LimitKind::PositionMin, angle, self.min_deg, self.margin_deg)
        } else if velocity.abs() > self.max_dps + self.margin_dps {
            breach(LimitKind::Velocity, velocity, self.max_dps, self.margin_dps)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{BusConfig, MotorConfig, Mounting, Robot, RobotConfig};

    fn guard(motor: MotorConfig) -> LimitGuard {
        let robot = Robot::try_from(
            RobotConfig::new(1000.0).with_bus(BusConfig::new("can0").with_motor(motor)),
        )
        .unwrap();
        LimitGuard::from_spec(&robot.joints()[0])
    }

    fn at(angle_deg: f64, velocity_dps: f64) -> JointSide {
        JointSide {
            angle_deg,
            velocity_dps,
            torque_nm: None,
        }
    }

    #[test]
    fn torque_further_out_is_refused_past_a_limit_and_back_in_passes() {
        let g = guard(
            MotorConfig::new(1)
                .position_limits(-10.0, 90.0)
                .velocity_limit(100.0),
        );
        // Inside: anything passes.
        assert!(!g.refuses(&at(0.0, 0.0), 5.0));
        assert!(!g.refuses(&at(0.0, 0.0), -5.0));
        // Past the top: up refused, down passes; past the bottom: the other way.
        assert!(g.refuses(&at(90.5, 0.0), 1.0));
        assert!(!g.refuses(&at(90.5, 0.0), -1.0));
        assert!(g.refuses(&at(-10.5, 0.0), -1.0));
        assert!(!g.refuses(&at(-10.5, 0.0), 1.0));
        // Zero torque is never refused.
        assert!(!g.refuses(&at(200.0, 500.0), 0.0));
        // Too fast: speeding up refused, braking passes, either way.
        assert!(g.refuses(&at(0.0, 120.0), 1.0));
        assert!(!g.refuses(&at(0.0, 120.0), -1.0));
        assert!(g.refuses(&at(0.0, -120.0), -1.0));
        assert!(!g.refuses(&at(0.0, -120.0), 1.0));
    }

    #[test]
    fn a_reversed_joint_is_judged_by_its_joint_sign() {
        let g = guard(
            MotorConfig::new(1)
                .position_limits(-10.0, 90.0)
                .direction(Mounting::Reversed),
        );
        // Motor-side -1 A is joint-side +1 A: up, refused past the top.
        assert!(g.refuses(&at(91.0, 0.0), -1.0));
        assert!(!g.refuses(&at(91.0, 0.0), 1.0));
    }

    #[test]
    fn a_joint_past_a_limit_by_more_than_its_margin_is_a_breach() {
        let g = guard(
            MotorConfig::new(1)
                .position_limits(-10.0, 90.0)
                .limit_margin(2.0)
                .velocity_limit(100.0),
        );
        assert_eq!(g.breach(&at(92.0, 0.0)), None);
        let top = g.breach(&at(92.5, 0.0)).unwrap();
        assert_eq!(
            (top.kind, top.limit, top.margin),
            (LimitKind::PositionMax, 90.0, 2.0)
        );
        assert_eq!(
            top.to_string(),
            "is at 92.5 deg, past its position_max_deg of 90 deg by more than its 2 deg margin"
        );
        assert_eq!(
            g.breach(&at(-12.5, 0.0)).unwrap().kind,
            LimitKind::PositionMin
        );
        // The velocity margin defaults to half the limit.
        assert_eq!(g.breach(&at(0.0, -150.0)), None);
        let fast = g.breach(&at(0.0, -151.0)).unwrap();
        assert_eq!(
            (fast.kind, fast.value, fast.margin),
            (LimitKind::Velocity, -151.0, 50.0)
        );
    }

    #[test]
    fn a_joint_without_limits_is_never_refused_nor_breached() {
        let g = guard(MotorConfig::new(1));
        assert!(!g.refuses(&at(1e6, 1e6), 30.0));
        assert_eq!(g.breach(&at(-1e6, -1e6)), None);
    }
}
