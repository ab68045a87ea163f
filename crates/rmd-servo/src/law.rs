//! The control law of one joint, as pure functions: what a mode asks of the law ([`Demand`]),
//! PD on the reference, the velocity mode's moving reference, the effort clamp, the torque the
//! servo sends when it runs the law itself.

use crate::config::JointServo;
use crate::trajectory::segment::Kin;

/// What a joint's mode asks of the law this tick: PD towards a reference (position and
/// velocity), plus a feed-forward torque. Every mode is one of these: hold (a position at
/// rest), position, velocity (a moving position), trajectory (its sample) with the reference;
/// effort (the feed-forward alone), zero torque and disabled (nothing) without.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Demand {
    /// Where the joint should be (the PD law's targets); `None`: no PD term.
    pub(crate) reference: Option<Kin>,
    /// Feed-forward torque (in effort mode the setpoint itself), N·m.
    pub(crate) effort_ff: f64,
}

impl Demand {
    /// No torque at all.
    pub(crate) const NONE: Demand = Demand {
        reference: None,
        effort_ff: 0.0,
    };

    /// The torque the law gives at position `p` and velocity `v`, before the effort limit:
    /// τ = kp·(r − p) + kd·(ṙ − v) + τ_ff, or τ_ff without a reference.
    pub(crate) fn effort(&self, joint: &JointServo, p: f64, v: f64) -> f64 {
        match self.reference {
            Some(r) => pd(joint, r.p, r.v, p, v) + self.effort_ff,
            None => self.effort_ff,
        }
    }
}

/// The torque the servo sends for `demand` at `p`, `v` when it runs the law itself (N·m,
/// within ±`max_effort_nm`), and whether it had to be clamped.
pub(crate) fn torque(joint: &JointServo, demand: &Demand, p: f64, v: f64) -> (f64, bool) {
    clamp_effort(demand.effort(joint, p, v), joint.limits.max_effort_nm)
}

/// τ = kp·(reference − position) + kd·(reference velocity − velocity), N·m.
pub(crate) fn pd(
    joint: &JointServo,
    reference_rad: f64,
    reference_rad_s: f64,
    position_rad: f64,
    velocity_rad_s: f64,
) -> f64 {
    joint.gains.kp_nm_per_rad * (reference_rad - position_rad)
        + joint.gains.kd_nm_s_per_rad * (reference_rad_s - velocity_rad_s)
}

/// `effort` within ±`max`; whether it had to be clamped. A value that is not a number is 0.
pub(crate) fn clamp_effort(effort_nm: f64, max_nm: f64) -> (f64, bool) {
    if effort_nm.is_nan() {
        return (0.0, true);
    }
    let clamped = effort_nm.clamp(-max_nm, max_nm);
    (clamped, clamped != effort_nm)
}

/// Advances the velocity mode's position reference by `velocity·dt`, keeping it within
/// max_effort/kp of the measured position (beyond that the P term is saturated anyway: no
/// wind-up when the joint is held back) and within the position limits. Returns the new
/// reference and the velocity the D term aims at (zero while the reference rests on a limit).
pub(crate) fn advance_velocity_reference(
    joint: &JointServo,
    reference_rad: f64,
    velocity_rad_s: f64,
    dt_s: f64,
    position_rad: f64,
) -> (f64, f64) {
    let mut r = reference_rad + velocity_rad_s * dt_s;
    let kp = joint.gains.kp_nm_per_rad;
    if kp > 0.0 {
        let window = joint.limits.max_effort_nm / kp;
        r = r.clamp(position_rad - window, position_rad + window);
    } else {
        r = position_rad;
    }
    let l = &joint.limits;
    let r = r.clamp(l.position_min_rad, l.position_max_rad);
    let at_limit = (r <= l.position_min_rad && velocity_rad_s < 0.0)
        || (r >= l.position_max_rad && velocity_rad_s > 0.0);
    (r, if at_limit { 0.0 } else { velocity_rad_s })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::config::{Gains, JointLimits, LimitSource, StalePolicy, StaleRule};

    /// A joint: kp 10 N·m/rad, kd 0.5 N·m·s/rad, ±1 rad, 2 rad/s, 2 N·m.
    pub(crate) fn joint() -> JointServo {
        JointServo {
            name: "j".into(),
            gains: Gains {
                kp_nm_per_rad: 10.0,
                kd_nm_s_per_rad: 0.5,
            },
            limits: JointLimits {
                position_min_rad: -1.0,
                position_max_rad: 1.0,
                max_velocity_rad_s: 2.0,
                max_acceleration_rad_s2: 10.0,
                max_jerk_rad_s3: 100.0,
                max_effort_nm: 2.0,
                position_min_from: LimitSource::ServoConfiguration,
                position_max_from: LimitSource::ServoConfiguration,
                velocity_from: LimitSource::ServoConfiguration,
            },
            stale: StaleRule {
                after: core::time::Duration::from_millis(100),
                policy: StalePolicy::Hold,
            },
        }
    }

    #[test]
    fn a_demand_is_pd_on_its_reference_plus_its_feed_forward_then_clamped() {
        let j = joint();
        let at = |p, v| Kin { p, v, a: 0.0 };
        let position = Demand {
            reference: Some(at(0.1, 0.2)),
            effort_ff: 0.25,
        };
        // 10 * (0.1 - 0.05) + 0.5 * (0.2 - 0.1) + 0.25 = 0.8
        assert!((position.effort(&j, 0.05, 0.1) - 0.8).abs() < 1e-12);
        assert_eq!(
            torque(&j, &position, 0.05, 0.1),
            (position.effort(&j, 0.05, 0.1), false)
        );
        // Far from its reference: clamped to max_effort_nm = 2.
        assert_eq!(torque(&j, &position, -1.0, 0.0), (2.0, true));
        let effort = Demand {
            reference: None,
            effort_ff: -1.5,
        };
        assert_eq!(torque(&j, &effort, 0.7, 3.0), (-1.5, false));
        assert_eq!(torque(&j, &Demand::NONE, 0.7, 3.0), (0.0, false));
    }

    #[test]
    fn pd_and_clamp() {
        let j = joint();
        assert!((pd(&j, 0.5, 1.0, 0.25, 0.0) - 3.0).abs() < 1e-12);
        assert_eq!(clamp_effort(3.0, 2.0), (2.0, true));
        assert_eq!(clamp_effort(-1.5, 2.0), (-1.5, false));
        assert_eq!(clamp_effort(f64::NAN, 2.0), (0.0, true));
    }

    #[test]
    fn the_velocity_reference_moves_stays_near_the_joint_and_stops_at_limits() {
        let j = joint();
        let (r, v) = advance_velocity_reference(&j, 0.0, 1.0, 0.01, 0.0);
        assert!((r - 0.01).abs() < 1e-12 && v == 1.0);
        // Held back: the reference waits within max_effort / kp = 0.2 rad of the joint.
        let (r, _) = advance_velocity_reference(&j, 0.5, 1.0, 0.01, 0.1);
        assert!((r - 0.3).abs() < 1e-12, "{r}");
        // At the upper limit going up: the reference stops there and so does the D term's aim.
        let (r, v) = advance_velocity_reference(&j, 0.995, 1.0, 0.01, 0.99);
        assert_eq!((r, v), (1.0, 0.0));
        // Going down from the limit is allowed.
        let (r, v) = advance_velocity_reference(&j, 1.0, -1.0, 0.01, 1.0);
        assert!((r - 0.99).abs() < 1e-12 && v == -1.0);
    }
}
