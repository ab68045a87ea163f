//! What a controller writes every tick: one torque command per joint (or, on a `motion` bus, a
//! motion-mode setpoint), and its user signals.
//!
//! Setters cannot fail silently: a command the loop cannot send as given (not a finite number,
//! a torque without a torque constant, a joint the robot does not have, a motion setpoint
//! beyond the joint's limits or the firmware's ranges) is zero torque for that joint, counted per joint in the report, and by default a fault that stops the run
//! (`loop.rejected_command`, see [`RejectedCommandPolicy`](crate::robot::RejectedCommandPolicy)).

use rmd_protocol::{IqControl, MitCommand};

use crate::joint::JointId;
use crate::mapping::JointMap;
use crate::motion::{MotionCommand, MotionMap};
pub use crate::rejection::Rejection;
use crate::robot::MAX_JOINTS;

/// Most user signals a controller can declare.
pub const MAX_SIGNALS: usize = 16;

/// The commands rejected during one tick.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Rejections {
    /// Per joint, in description order.
    pub(crate) per_joint: [u16; MAX_JOINTS],
    /// Commands for joints the robot does not have.
    pub(crate) unknown_joint: u16,
    /// The first rejection of the tick.
    pub(crate) first: Option<(Option<JointId>, Rejection)>,
    /// `set_signal` calls with an undeclared index.
    pub(crate) unknown_signal: u16,
}

impl Rejections {
    pub(crate) const NONE: Self = Self {
        per_joint: [0; MAX_JOINTS],
        unknown_joint: 0,
        first: None,
        unknown_signal: 0,
    };

    fn reject(&mut self, joint: Option<JointId>, why: Rejection) {
        match joint {
            Some(j) => {
                let slot = &mut self.per_joint[j.index()];
                *slot = slot.saturating_add(1);
            }
            None => self.unknown_joint = self.unknown_joint.saturating_add(1),
        }
        self.first.get_or_insert((joint, why));
    }
}

/// A motion-mode command packed for its motor, and whether its feed-forward torque was
/// limited to the joint's current limit.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct PackedMotion {
    pub(crate) command: MitCommand,
    pub(crate) limited: bool,
}

/// Where a controller's motion setpoints go: per joint, its conversion (`None` off a `motion`
/// bus) and this tick's packed setpoint (`None`: none given, the current is sent).
#[derive(Debug)]
pub(crate) struct MotionSlots<'a> {
    pub(crate) maps: &'a [Option<MotionMap>],
    pub(crate) given: &'a mut [Option<PackedMotion>],
}

/// This tick's torque commands (they start at zero every tick), motion setpoints and user
/// signals.
///
/// The loop clamps each current to the joint's `current_limit_amps` when it builds the frame
/// (the motor itself does not limit 0x280 commands) and counts the clamps.
#[derive(Debug)]
pub struct Commands<'a> {
    amps: &'a mut [f64],
    maps: &'a [JointMap],
    motion: MotionSlots<'a>,
    signals: &'a mut [f64],
    rejections: &'a mut Rejections,
}

impl<'a> Commands<'a> {
    pub(crate) fn new(
        amps: &'a mut [f64],
        maps: &'a [JointMap],
        motion: MotionSlots<'a>,
        signals: &'a mut [f64],
        rejections: &'a mut Rejections,
    ) -> Self {
        Self {
            amps,
            maps,
            motion,
            signals,
            rejections,
        }
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.amps.len()
    }

    /// Whether there are no joints.
    pub fn is_empty(&self) -> bool {
        self.amps.is_empty()
    }

    fn slot(&mut self, joint: JointId) -> Option<(&mut f64, JointMap)> {
        let map = *self.maps.get(joint.index())?;
        Some((&mut self.amps[joint.index()], map))
    }

    fn reject(&mut self, joint: JointId, why: Rejection) {
        let known = joint.index() < self.amps.len();
        if known {
            self.amps[joint.index()] = 0.0;
            if let Some(given) = self.motion.given.get_mut(joint.index()) {
                *given = None;
            }
        }
        self.rejections.reject(known.then_some(joint), why);
    }

    /// Gives the joint a motion-mode setpoint (its bus must be `exchange = "motion"`): the
    /// motor runs the law itself until the next tick's command. A joint given one this tick is
    /// sent it, whatever current it was also given.
    pub fn set_motion(&mut self, joint: JointId, command: MotionCommand) {
        let i = joint.index();
        let map = match self.motion.maps.get(i) {
            Some(Some(map)) => map,
            // (No map at all: no joint of the robot is on a `motion` bus.)
            Some(None) | None if i < self.amps.len() => {
                return self.reject(joint, Rejection::NoMotionMode);
            }
            Some(None) | None => return self.reject(joint, Rejection::UnknownJoint),
        };
        match map.command(&command) {
            Ok((command, limited)) => {
                self.amps[i] = 0.0;
                self.motion.given[i] = Some(PackedMotion { command, limited });
            }
            Err(why) => self.reject(joint, why),
        }
    }

    /// Sets the joint's torque current in amperes, joint sign (the configured direction is
    /// applied).
    pub fn set_current(&mut self, joint: JointId, joint_amps: f64) {
        if !joint_amps.is_finite() {
            return self.reject(joint, Rejection::NotFinite);
        }
        match self.slot(joint) {
            Some((slot, map)) => *slot = map.motor_amps(joint_amps),
            None => self.reject(joint, Rejection::UnknownJoint),
        }
    }

    /// Sets the joint's torque in N*m (needs the joint's torque constant).
    pub fn set_torque(&mut self, joint: JointId, joint_nm: f64) {
        if !joint_nm.is_finite() {
            return self.reject(joint, Rejection::NotFinite);
        }
        match self.slot(joint) {
            Some((slot, map)) => match map.motor_amps_for_torque(joint_nm) {
                Some(amps) => *slot = amps,
                None => self.reject(joint, Rejection::NoTorqueConstant),
            },
            None => self.reject(joint, Rejection::UnknownJoint),
        }
    }

    /// Sets the joint's raw torque command (motor sign, no direction applied).
    pub fn set_raw(&mut self, joint: JointId, iq_control: IqControl) {
        match self.slot(joint) {
            Some((slot, _)) => *slot = iq_control.amps(),
            None => self.reject(joint, Rejection::UnknownJoint),
        }
    }

    /// The joint's command so far, motor-side amperes (before clamping).
    pub fn motor_amps(&self, joint: JointId) -> Option<f64> {
        self.amps.get(joint.index()).copied()
    }

    /// Zero torque for every joint (and no motion setpoint).
    pub fn zero_all(&mut self) {
        self.amps.fill(0.0);
        self.motion.given.fill(None);
    }

    /// Writes user signal `index` (in the order of [`Controller::signals`](crate::Controller::signals)):
    /// carried out with the telemetry of this tick. An undeclared index is counted in the report.
    pub fn set_signal(&mut self, index: usize, value: f64) {
        match self.signals.get_mut(index) {
            Some(slot) => *slot = value,
            None => {
                self.rejections.unknown_signal = self.rejections.unknown_signal.saturating_add(1)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{BusConfig, MotorConfig, Robot, RobotConfig};

    #[test]
    fn rejected_commands_are_zero_and_counted_per_joint() {
        let robot = Robot::try_from(
            RobotConfig::new(100.0).with_bus(
                BusConfig::new("can0")
                    .with_motor(MotorConfig::new(1).torque_constant(2.0))
                    .with_motor(MotorConfig::new(2).direction(crate::robot::Mounting::Reversed)),
            ),
        )
        .unwrap();
        let maps: Vec<_> = robot.joints().iter().map(JointMap::from_spec).collect();
        let mut amps = vec![0.0; 2];
        let mut signals = [0.0; 2];
        let mut rejections = Rejections::NONE;
        let mut given = [None; 2];
        let motion = MotionSlots {
            maps: &[None, None],
            given: &mut given,
        };
        let mut cmd = Commands::new(&mut amps, &maps, motion, &mut signals, &mut rejections);
        let [a, b] = [JointId::from_index(0), JointId::from_index(1)];
        cmd.set_torque(a, 4.0);
        cmd.set_current(b, 1.5);
        assert_eq!(cmd.motor_amps(a), Some(2.0));
        assert_eq!(cmd.motor_amps(b), Some(-1.5));
        cmd.set_current(b, f64::NAN);
        cmd.set_torque(b, 1.0);
        cmd.set_current(JointId::from_index(7), 1.0);
        cmd.set_signal(1, 3.5);
        cmd.set_signal(2, 1.0);
        cmd.set_motion(a, MotionCommand::hold(0.0, 1.0, 0.0));
        assert_eq!(cmd.motor_amps(b), Some(0.0));
        // A motion setpoint off a `motion` bus is refused: joint a's torque is zero too.
        assert_eq!(amps, [0.0, 0.0]);
        assert_eq!(signals, [0.0, 3.5]);
        assert_eq!(rejections.per_joint[..2], [1, 2]);
        assert_eq!(rejections.unknown_joint, 1);
        assert_eq!(rejections.unknown_signal, 1);
        assert_eq!(rejections.first, Some((Some(b), Rejection::NotFinite)));
    }
}
