//! A joint on a motion bus (MyActuator V3, `exchange = "motion"`), as a pure function: the
//! mode's [`Demand`] becomes one motion-mode setpoint, and the motor runs the servo's PD law
//! itself, with the servo's gains, between the loop's ticks.
//!
//! Units: the servo's gains are per radian (N·m/rad, N·m·s/rad), a [`MotionCommand`]'s per
//! degree (N·m/deg, N·m per deg/s): a gain per degree is the gain per radian times π/180.
//!
//! The effort limit: where the law would ask more than `max_effort_nm` at this tick's
//! measurement, the position setpoint is moved towards the joint (the velocity setpoint when
//! kp is 0) so that the motor's law gives exactly the limit there. Setpoints stay within the
//! servo's limits and the robot description's, so the loop never refuses one.

use rmd_loop::MotionCommand;

use crate::config::{JointServo, MotionLimits};
use crate::law::{Demand, clamp_effort};

/// Radians per degree: a gain per degree is this many times the same gain per radian.
const RAD_PER_DEG: f64 = core::f64::consts::PI / 180.0;

/// One tick's motion-mode setpoint for a joint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct MotionStep {
    /// What goes to the motor (joint units, see [`MotionCommand`]).
    pub(crate) command: MotionCommand,
    /// The torque the motor's law gives at this tick's measurement (within
    /// ±`max_effort_nm`), N·m.
    pub(crate) effort_nm: f64,
    /// Whether the law asked more than `max_effort_nm`.
    pub(crate) clamped: bool,
}

/// The motion-mode setpoint of `demand` for `joint`, measured at position `p` (rad) and
/// velocity `v` (rad/s).
pub(crate) fn motion_step(
    joint: &JointServo,
    limits: &MotionLimits,
    demand: &Demand,
    p: f64,
    v: f64,
) -> MotionStep {
    let (effort_nm, clamped) = clamp_effort(demand.effort(joint, p, v), joint.limits.max_effort_nm);
    let Some(r) = demand.reference else {
        return MotionStep {
            command: MotionCommand::torque(effort_nm),
            effort_nm,
            clamped,
        };
    };
    let (kp, kd) = (joint.gains.kp_nm_per_rad, joint.gains.kd_nm_s_per_rad);
    let ff = demand.effort_ff;
    // Targets for which the law gives `effort_nm` at (p, v): the reference's own unless clamped.
    let (target_p, target_v, ff) = if !clamped {
        (r.p, r.v, ff)
    } else if kp > 0.0 {
        (p + (effort_nm - kd * (r.v - v) - ff) / kp, r.v, ff)
    } else if kd > 0.0 {
        (r.p, v + (effort_nm - ff) / kd, ff)
    } else {
        (r.p, r.v, effort_nm)
    };
    let command = MotionCommand {
        position_deg: target_p
            .to_degrees()
            .clamp(limits.position_min_deg, limits.position_max_deg),
        velocity_dps: target_v
            .to_degrees()
            .clamp(-limits.velocity_max_dps, limits.velocity_max_dps),
        kp_nm_per_deg: kp * RAD_PER_DEG,
        kd_nm_per_dps: kd * RAD_PER_DEG,
        torque_nm: ff,
    };
    MotionStep {
        command,
        effort_nm,
        clamped,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law::tests::joint;
    use crate::step;

    /// The law the motor runs (joint units, per degree), at position `p_deg` and velocity
    /// `v_dps`.
    fn motor_law(c: &MotionCommand, p_deg: f64, v_dps: f64) -> f64 {
        c.kp_nm_per_deg * (c.position_deg - p_deg)
            + c.kd_nm_per_dps * (c.velocity_dps - v_dps)
            + c.torque_nm
    }

    fn limits() -> MotionLimits {
        MotionLimits {
            position_min_deg: -1f64.to_degrees(),
            position_max_deg: 1f64.to_degrees(),
            velocity_max_dps: 2f64.to_degrees(),
        }
    }

    #[test]
    fn the_servos_gains_and_targets_go_out_per_degree_and_the_motor_runs_the_same_law() {
        let j = joint();
        let demand = step::position(0.3, 0.5, 0.25);
        let (p, v) = (0.25, 0.2);
        let out = motion_step(&j, &limits(), &demand, p, v);
        let c = out.command;
        assert!((c.position_deg - 0.3f64.to_degrees()).abs() < 1e-12);
        assert!((c.velocity_dps - 0.5f64.to_degrees()).abs() < 1e-12);
        // 10 N·m/rad is 0.1745 N·m/deg; 0.5 N·m·s/rad is 0.008727 N·m per deg/s.
        assert!((c.kp_nm_per_deg - 10.0 * core::f64::consts::PI / 180.0).abs() < 1e-12);
        assert!((c.kd_nm_per_dps - 0.5 * core::f64::consts::PI / 180.0).abs() < 1e-12);
        assert_eq!(c.torque_nm, 0.25);
        assert!(!out.clamped);
        // The motor's law in degrees is the servo's in radians.
        let servo = demand.effort(&j, p, v);
        assert!((motor_law(&c, p.to_degrees(), v.to_degrees()) - servo).abs() < 1e-12);
        assert!((out.effort_nm - servo).abs() < 1e-12);
    }

    #[test]
    fn effort_disabled_and_zero_torque_are_pure_torque() {
        let j = joint();
        let out = motion_step(&j, &limits(), &step::effort(-1.5), 0.4, 1.0);
        assert_eq!(out.command, MotionCommand::torque(-1.5));
        assert_eq!((out.effort_nm, out.clamped), (-1.5, false));
        let off = motion_step(&j, &limits(), &Demand::NONE, 0.4, 1.0);
        assert_eq!(off.command, MotionCommand::torque(0.0));
        // Beyond max_effort_nm (2 N·m): clamped as in torque mode.
        let out = motion_step(&j, &limits(), &step::effort(5.0), 0.0, 0.0);
        assert_eq!(out.command, MotionCommand::torque(2.0));
        assert!(out.clamped);
    }

    #[test]
    fn a_step_too_far_for_the_effort_limit_moves_the_target_so_the_law_gives_the_limit() {
        let j = joint();
        // 10 * (0.9 - 0) = 9 N·m asked, 2 allowed.
        let out = motion_step(&j, &limits(), &step::hold(0.9), 0.0, 0.1);
        assert!(out.clamped);
        assert_eq!(out.effort_nm, 2.0);
        let c = out.command;
        assert!(
            (motor_law(&c, 0.0, 0.1f64.to_degrees()) - 2.0).abs() < 1e-9,
            "{c:?}"
        );
        assert!(c.position_deg > 0.0 && c.position_deg < 0.9f64.to_degrees());
        // Without kp the velocity target moves instead; without either, the feed-forward.
        let mut soft = joint();
        soft.gains.kp_nm_per_rad = 0.0;
        let out = motion_step(&soft, &limits(), &step::position(0.0, 1.9, 0.0), 0.0, -4.0);
        assert!(out.clamped);
        assert!((motor_law(&out.command, 0.0, -4f64.to_degrees()) - 2.0).abs() < 1e-9);
        soft.gains.kd_nm_s_per_rad = 0.0;
        let out = motion_step(&soft, &limits(), &step::position(0.0, 0.0, 3.0), 0.0, 0.0);
        assert_eq!(out.command.torque_nm, 2.0);
    }

    #[test]
    fn setpoints_stay_within_the_limits_the_loop_checks() {
        let j = joint();
        let lim = MotionLimits {
            position_min_deg: -50.0,
            position_max_deg: 50.0,
            velocity_max_dps: 90.0,
        };
        // A hold beyond the limits (a joint pushed out while disabled, then enabled): the
        // target is the limit, never refused.
        let out = motion_step(&j, &lim, &step::hold(1.2), 1.2, 0.0);
        assert_eq!(out.command.position_deg, 50.0);
        let out = motion_step(&j, &lim, &step::position(0.0, -3.0, 0.0), 0.0, 0.0);
        assert_eq!(out.command.velocity_dps, -90.0);
    }
}
