//! Motion mode (MyActuator V3, `exchange = "motion"`): the motor runs
//! `IqRef = [kp (p_des - p) + kd (v_des - v) + t_ff] / KT` itself, every tick with the loop's
//! setpoint. A controller writes a [`MotionCommand`] in joint units; the loop converts it to the
//! output shaft's units (radians from the motor's zero, the joint's direction applied) and packs
//! it with the ranges of the firmware the start-up read.
//!
//! Joint and output shaft: `output_deg = sign * (joint_deg + zero_offset_deg)` (the inverse of
//! the joint mapping, see [`mapping`](crate::mapping)); gains are the same at both (a joint
//! degree is an output degree), converted from per degree to per radian; torque changes sign
//! with the direction.

use rmd_protocol::{MitCommand, MitFeedback, MitRanges};

use crate::rejection::Rejection;
use crate::robot::JointSpec;

/// Degrees per radian: a gain per degree is this many times the same gain per radian.
const DEG_PER_RAD: f64 = 180.0 / core::f64::consts::PI;

/// What a controller gives a joint in motion mode, in joint units: the motor applies
/// `torque = kp (position - angle) + kd (velocity - angular velocity) + torque_nm` at the
/// output shaft, every tick with this setpoint.
///
/// ```
/// use rmd_loop::MotionCommand;
/// // Hold 30 degrees with 2 N*m per degree and 0.05 N*m per deg/s.
/// let hold = MotionCommand::hold(30.0, 2.0, 0.05);
/// assert_eq!(hold.velocity_dps, 0.0);
/// assert_eq!(hold.torque_nm, 0.0);
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct MotionCommand {
    /// Position setpoint, joint degrees (within the joint's position limits).
    pub position_deg: f64,
    /// Velocity setpoint, joint deg/s (within the joint's velocity limit).
    pub velocity_dps: f64,
    /// Stiffness, N*m per degree (0 or more).
    pub kp_nm_per_deg: f64,
    /// Damping, N*m per deg/s (0 or more).
    pub kd_nm_per_dps: f64,
    /// Feed-forward torque, joint N*m (its magnitude is limited to the joint's current limit
    /// times its torque constant, and counted when it is).
    pub torque_nm: f64,
}

impl MotionCommand {
    /// Holds `position_deg` with stiffness `kp_nm_per_deg` and damping `kd_nm_per_dps`.
    pub fn hold(position_deg: f64, kp_nm_per_deg: f64, kd_nm_per_dps: f64) -> Self {
        Self {
            position_deg,
            velocity_dps: 0.0,
            kp_nm_per_deg,
            kd_nm_per_dps,
            torque_nm: 0.0,
        }
    }

    /// Pure torque: zero gains, `torque_nm` feed-forward.
    pub fn torque(torque_nm: f64) -> Self {
        Self {
            torque_nm,
            ..Self::default()
        }
    }
}

/// How a controller commands a joint, declared with
/// [`Controller::command_kind`](crate::Controller::command_kind) and checked when the loop is
/// built: a joint on a bus that cannot carry the kind is refused then, not at run time.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum CommandKind {
    /// Currents or torques ([`Commands::set_current`](crate::Commands::set_current),
    /// [`set_torque`](crate::Commands::set_torque)): every exchange (on a `motion` bus as
    /// feed-forward torque with zero gains).
    #[default]
    Current,
    /// Motion-mode setpoints ([`Commands::set_motion`](crate::Commands::set_motion)), and
    /// currents or torques as well: a joint on a `motion` bus only.
    Motion,
}

/// A motion-mode joint's conversions from joint units to the motor's, with the ranges its
/// commands are packed with.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct MotionMap {
    /// The firmware's field ranges (from the firmware date the start-up read).
    pub(crate) ranges: MitRanges,
    sign: f64,
    zero_offset_deg: f64,
    gear_ratio: f64,
    /// The torque constant, joint side, N*m per A (checked present and above zero).
    torque_constant: f64,
    /// The largest feed-forward torque, output N*m: the current limit times the torque
    /// constant, within the ranges.
    max_torque_nm: f64,
    position_min_deg: f64,
    position_max_deg: f64,
    velocity_max_dps: f64,
}

impl MotionMap {
    /// The map of `joint` (on a `motion` bus: it has a torque constant, checked with the
    /// description) with `ranges`.
    pub(crate) fn new(joint: &JointSpec, ranges: MitRanges) -> Self {
        let torque_constant = joint.torque_constant_nm_per_amp.unwrap_or(0.0);
        Self {
            ranges,
            sign: joint.direction.sign(),
            zero_offset_deg: joint.zero_offset_deg,
            gear_ratio: joint.gear_ratio,
            torque_constant,
            max_torque_nm: (joint.current_limit.amps() * torque_constant).min(ranges.torque_nm()),
            position_min_deg: joint.limits.position_min_deg,
            position_max_deg: joint.limits.position_max_deg,
            velocity_max_dps: joint.limits.velocity_max_dps,
        }
    }

    /// The same map with other ranges.
    pub(crate) fn with_ranges(self, ranges: MitRanges) -> Self {
        Self {
            ranges,
            max_torque_nm: self.max_torque_nm.min(ranges.torque_nm()),
            ..self
        }
    }

    /// The packed command for `c`, and whether its feed-forward torque was limited; a value
    /// that is not finite, a setpoint beyond the joint's limits, or a field beyond the
    /// firmware's ranges is refused.
    pub(crate) fn command(&self, c: &MotionCommand) -> Result<(MitCommand, bool), Rejection> {
        let values = [
            c.position_deg,
            c.velocity_dps,
            c.kp_nm_per_deg,
            c.kd_nm_per_dps,
            c.torque_nm,
        ];
        if values.iter().any(|v| !v.is_finite()) {
            return Err(Rejection::NotFinite);
        }
        if c.position_deg < self.position_min_deg
            || c.position_deg > self.position_max_deg
            || c.velocity_dps.abs() > self.velocity_max_dps
        {
            return Err(Rejection::BeyondJointLimits);
        }
        let t = self.sign * c.torque_nm;
        let t_limited = t.clamp(-self.max_torque_nm, self.max_torque_nm);
        let output_deg = self.sign * (c.position_deg + self.zero_offset_deg);
        MitCommand::from_si(
            self.ranges,
            output_deg.to_radians(),
            (self.sign * c.velocity_dps).to_radians(),
            c.kp_nm_per_deg * DEG_PER_RAD,
            c.kd_nm_per_dps * DEG_PER_RAD,
            t_limited,
        )
        .map(|packed| (packed, t_limited != t))
        .map_err(|_| Rejection::OutOfMotionRange)
    }

    /// Zero gains and `motor_amps` (motor sign, already within the current limit) as
    /// feed-forward torque, limited to the ranges.
    #[inline]
    pub(crate) fn torque_command(&self, motor_amps: f64) -> MitCommand {
        let t = (motor_amps * self.torque_constant).clamp(-self.max_torque_nm, self.max_torque_nm);
        // Zero position and velocity are within every range, zero gains too, and `t` within
        // the torque range: packing cannot fail; were it to, zero torque is the answer.
        MitCommand::from_si(self.ranges, 0.0, 0.0, 0.0, 0.0, t)
            .unwrap_or_else(|_| self.zero_torque())
    }

    /// Zero torque: zero gains, no feed-forward.
    pub(crate) fn zero_torque(&self) -> MitCommand {
        zero_torque(self.ranges)
    }

    /// The motor side of a motion-mode reply: continuous rotor angle (deg), rotor speed (dps)
    /// and torque current (A, motor sign).
    #[inline]
    pub(crate) fn motor_side(&self, f: &MitFeedback) -> (f64, f64, f64) {
        (
            f.position_rad() * DEG_PER_RAD * self.gear_ratio,
            f.velocity_rad_s() * DEG_PER_RAD * self.gear_ratio,
            f.torque_nm() / self.torque_constant,
        )
    }

    /// The motor-side current a packed command's feed-forward torque stands for (A, motor
    /// sign): what the telemetry reports as the command.
    pub(crate) fn feed_forward_amps(&self, c: &MitCommand) -> f64 {
        c.torque_nm() / self.torque_constant
    }
}

/// Zero torque in `ranges`: zero gains, no feed-forward, zero setpoints (zero lies within
/// every field's range).
pub(crate) fn zero_torque(ranges: MitRanges) -> MitCommand {
    match MitCommand::from_si(ranges, 0.0, 0.0, 0.0, 0.0, 0.0) {
        Ok(zero) => zero,
        // Not reached (see above); the middle codes are the same command.
        Err(_) => match MitCommand::from_raw(ranges, [0x8000, 0x800, 0, 0, 0x800]) {
            Ok(zero) => zero,
            Err(_) => unreachable!("12-bit codes below 4096 are valid"),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{BusConfig, ExchangeKind, MotorConfig, Mounting, Robot, RobotConfig};

    fn joint(direction: Mounting) -> JointSpec {
        let motor = MotorConfig::new(1)
            .gear_ratio(9.0)
            .torque_constant(2.0)
            .current_limit(5.0)
            .zero_offset_deg(10.0)
            .direction(direction)
            .position_limits(-90.0, 90.0);
        let robot = Robot::try_from(
            RobotConfig::new(500.0).with_bus(
                BusConfig::new("can0")
                    .protocol("myactuator-v3")
                    .exchange(ExchangeKind::Motion)
                    .with_motor(motor),
            ),
        )
        .unwrap();
        robot.joints()[0].clone()
    }

    #[test]
    fn joint_units_become_output_units_with_the_direction() {
        for (direction, sign) in [(Mounting::Normal, 1.0), (Mounting::Reversed, -1.0)] {
            let map = MotionMap::new(&joint(direction), MitRanges::V4_3);
            let c = MotionCommand {
                position_deg: 20.0,
                velocity_dps: 30.0,
                kp_nm_per_deg: 0.5,
                kd_nm_per_dps: 0.01,
                torque_nm: 3.0,
            };
            let (packed, limited) = map.command(&c).unwrap();
            assert!(!limited);
            // Output: sign * (20 + 10) degrees.
            assert!((packed.position_rad() - sign * 30f64.to_radians()).abs() < 1e-3);
            assert!((packed.velocity_rad_s() - sign * 30f64.to_radians()).abs() < 0.03);
            assert!((packed.kp() - 0.5 * DEG_PER_RAD).abs() < 0.2);
            assert!((packed.kd() - 0.01 * DEG_PER_RAD).abs() < 0.002);
            assert!((packed.torque_nm() - sign * 3.0).abs() < 0.02);
        }
    }

    #[test]
    fn bad_setpoints_are_refused_and_torque_is_limited() {
        let map = MotionMap::new(&joint(Mounting::Normal), MitRanges::V4_3);
        let ok = MotionCommand::hold(0.0, 1.0, 0.01);
        assert!(map.command(&ok).is_ok());
        let beyond = MotionCommand::hold(91.0, 1.0, 0.01);
        assert_eq!(map.command(&beyond), Err(Rejection::BeyondJointLimits));
        let nan = MotionCommand::hold(f64::NAN, 1.0, 0.01);
        assert_eq!(map.command(&nan), Err(Rejection::NotFinite));
        // kp 10 N*m/deg is 573 N*m/rad: beyond V4.3's 0..=500.
        let stiff = MotionCommand::hold(0.0, 10.0, 0.01);
        assert_eq!(map.command(&stiff), Err(Rejection::OutOfMotionRange));
        let negative = MotionCommand::hold(0.0, -1.0, 0.0);
        assert_eq!(map.command(&negative), Err(Rejection::OutOfMotionRange));
        // 5 A * 2 N*m/A = 10 N*m at most.
        let (packed, limited) = map.command(&MotionCommand::torque(15.0)).unwrap();
        assert!(limited);
        assert!((packed.torque_nm() - 10.0).abs() < 0.02);
        let t = map.torque_command(-2.0);
        assert!((t.torque_nm() + 4.0).abs() < 0.02);
        assert_eq!((t.kp(), t.kd()), (0.0, 0.0));
        let zero = map.zero_torque();
        assert!(zero.torque_nm().abs() < 0.01 && zero.kp() == 0.0 && zero.kd() == 0.0);
    }
}
